"""Patterns that validate text from outside: they hold for the whole text, in ASCII only.

Three traps of Python's `re` that a validator must not fall into (issue 39: the ids `gx\\n` and
`f-a\\n` were admitted and listed as actors):

- `$` also matches just before a final newline: `re.match(r"^[a-z]+$", "gx\\n")` succeeds. A
  validator calls `fullmatch`, or ends its pattern with `END`; never `match`/`search` on `$`.
- With a `str` pattern, `\\d` matches every Unicode digit (Arabic-Indic '٣'), `\\w` every
  letter (Cyrillic 'а', fullwidth 'ａ'), and `[a-z]` under IGNORECASE the Kelvin sign 'K'.
  Validators spell their classes as ASCII ranges (`[0-9]`, `[A-Za-z]`) and compile with
  `re.ASCII`. (`str.isdigit()` and `int()` have the same trap: `int("٣") == 3`.)
- msgspec's `Meta(pattern=...)` runs `re.search`, so its patterns need both anchors, and it
  copies them verbatim into the JSON Schema (`carlaverse schema --json`), whose regexes are
  ECMA-262: there `\\Z` is no anchor (a plain `Z`, or an error with the `u` flag). `END`,
  "no character follows" (`(?![\\s\\S])`), is the end of the text in both dialects.
"""

from __future__ import annotations

import ast
import re

# The end of the text in Python's `re` and in ECMA-262 alike; `$` is not (Python: also before
# a final newline) and neither is `\Z` (ECMA: not an anchor).
END = r"(?![\s\S])"


# How to say a pattern to a person: a config error shows these words, never the regex.
_WORDS: dict[str, str] = {}
_EXPECTED = re.compile(r"Expected `str` matching regex (?P<quoted>'(?:[^'\\]|\\.)*'|"
                       r'"(?:[^"\\]|\\.)*")')  # fmt: skip


def anchored(body: str, words: str = "") -> str:
    """`body` made to hold for the whole text, in both Python and JSON Schema (ECMA-262):
    for msgspec `Meta(pattern=...)`, which searches and which JSON Schema copies. `words`,
    if given, is what an error says instead of the pattern ("binaural, stereo or 5.1")."""
    pattern = f"^(?:{body}){END}"
    if words:
        _WORDS[pattern] = words
    return pattern


def readable(message: str) -> str:
    """A msgspec validation message with each pattern it quotes said in words: the registered
    ones (`anchored(..., words=)`) as such, any other without its anchors."""

    def say(found: re.Match[str]) -> str:
        pattern = ast.literal_eval(found["quoted"])  # msgspec quotes it as Python's repr
        words = _WORDS.get(pattern)
        if words:
            return f"Expected {words}"
        return f"Expected text of the form `{pattern.removeprefix('^(?:').removesuffix(')' + END)}`"

    return _EXPECTED.sub(say, message)


def whole_ascii(body: str) -> re.Pattern[str]:
    """`body` compiled to hold for the whole text whichever of `match`, `search` or
    `fullmatch` is called, with `\\d`, `\\w` and `\\s` meaning ASCII only."""
    return re.compile(anchored(body), re.ASCII)


def is_ascii_decimal(text: str) -> bool:
    """Whether `text` is one or more ASCII digits: what `int()` should be given from outside
    (`str.isdigit()` is also true for '٣' and '²')."""
    return text.isascii() and text.isdecimal()
