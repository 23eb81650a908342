"""The config tab: a tree of a schema's sections, a form for the chosen one, errors by path.

Values typed here are handed to the strict decoder as YAML would give them (`12` a number,
`abc` a string), so the decoder — not the page — says what is wrong, in the words
`carlaverse config validate` uses; the file is written only when it decodes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from nicegui import ui
from nicegui.elements.mixins.validation_element import ValidationElement
from nicegui.elements.mixins.value_element import ValueElement

from carlaverse.config import ConfigError
from carlaverse.launcher.config_draft import ConfigDraft, FieldError, config_kinds
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.schema_tree import Leaf, Section

DEFAULT_FILE = "bike-sim"


class ConfigEditor:
    """One browser's editor: the draft it holds and the widgets that show it."""

    def __init__(self, files: ConfigDir) -> None:
        self.files = files
        self.draft: ConfigDraft | None = None
        self.errors: list[FieldError] = []
        self._build()

    def _build(self) -> None:
        with ui.row().classes("w-full items-end gap-3"):
            self.source = ui.input("open (in the config dir, or shipped)", value=DEFAULT_FILE)
            self.source.props("data-testid=config-source").classes("w-64")
            self.kind = ui.select(["auto", *config_kinds()], value="auto", label="schema")
            self.kind.classes("w-32")
            self.target = ui.input("save to (in the config dir)", value="bike.yaml")
            self.target.props("data-testid=config-target").classes("w-96")
            ui.button("Open", icon="folder_open", on_click=self.open).props(
                "data-testid=config-open"
            )
            ui.button("New", icon="note_add", on_click=self.new).props("data-testid=config-new")
            ui.button("Save", icon="save", on_click=self.save).props("data-testid=config-save")
        self.status = ui.label("").props("data-testid=config-status").classes("text-sm")
        self.error_box = ui.column().props("data-testid=config-errors").classes("gap-0")
        with ui.row().classes("w-full no-wrap items-start gap-4"):
            self.tree = ui.tree([], on_select=self._on_select).classes("w-64 border rounded")
            self.tree.props("data-testid=config-tree selected-color=primary")
            self.form = ui.column().classes("grow gap-1")

    def open(self) -> None:
        """Edit the file named in `open`, with the schema chosen or told by the file."""
        kind = None if self.kind.value == "auto" else self.kind.value
        try:
            draft = ConfigDraft.open(self.files, self.source.value, Path(self.target.value), kind)
        except ConfigError as exc:
            self._say(str(exc), ok=False)
            return
        self._edit(draft, f"{draft.kind} config from {self.source.value}")

    def new(self) -> None:
        """Start an empty file of the chosen schema: every field at its default."""
        if self.kind.value == "auto":
            self._say("choose a schema for the new file", ok=False)
            return
        draft = ConfigDraft(self.kind.value, Path(self.target.value), self.files)
        self._edit(draft, "new, all defaults")

    def _edit(self, draft: ConfigDraft, what: str) -> None:
        self.draft = draft
        self.tree.props["nodes"] = [_tree_nodes(draft.tree, set())]
        self.tree.update()
        self.tree.expand()
        self._revalidate()
        self._say(f"{draft.kind}: {what}", ok=True)
        self._show_section("")

    def save(self) -> None:
        if self.draft is None:
            self._say("open a file first", ok=False)
            return
        self.draft.target = Path(self.target.value)
        self.errors = self.draft.save()
        self._show_errors()
        self._say(*self.draft.status())

    def _on_select(self, event: Any) -> None:
        if event.value is not None:
            self._show_section("" if event.value == "root" else event.value)

    def _show_section(self, path: str) -> None:
        assert self.draft is not None
        section = next(s for s in self.draft.tree.walk() if s.path == path)
        self.form.clear()
        with self.form:
            ui.label(path or "(top level)").classes("font-mono text-md font-medium")
            for leaf in section.leaves:
                self._leaf_input(leaf)
        self._mark_fields()

    def _leaf_input(self, leaf: Leaf) -> None:
        assert self.draft is not None
        value = self.draft.value(leaf.path)
        hint = " · ".join(p for p in (leaf.bounds, f"default {_show(leaf.default)}") if p)
        widget: ValueElement
        if leaf.kind == "bool":
            widget = ui.switch(leaf.name, value=bool(value))
        elif leaf.kind == "choice":
            widget = ui.select(
                list(leaf.choices), label=leaf.name, value=value,
                validation=lambda _v: self._error_at(leaf.path),
            )  # fmt: skip
        else:
            widget = ui.input(
                leaf.name, value=_show(value), validation=lambda _v: self._error_at(leaf.path)
            ).classes("w-96")
        widget.props(f'data-path="{leaf.path}" hint="{hint}" dense')
        widget.on_value_change(lambda e: self._edited(leaf, e.value))

    def _edited(self, leaf: Leaf, value: Any) -> None:
        assert self.draft is not None
        if value is None or value == "":
            self.draft.unset(leaf.path)
        elif leaf.kind in ("bool", "choice", "text"):
            self.draft.set(leaf.path, value)
        else:
            try:
                self.draft.set(leaf.path, yaml.safe_load(str(value)))
            except yaml.YAMLError:
                self.errors = [FieldError(leaf.path, f"not YAML: {value!r}")]
                self._show_errors()
                self._say(f"not valid: {self.errors[0]}", ok=False)
                return
        self._revalidate()

    def _revalidate(self) -> None:
        assert self.draft is not None
        self.errors = self.draft.validate()
        self._show_errors()
        self._say(*self.draft.status())  # an earlier save's verdict no longer holds

    def _show_errors(self) -> None:
        if self.draft is not None:  # a mark on every section above an error
            flagged = {p for e in self.errors for p in [*_ancestors(e.path), e.path]}
            self.tree.props["nodes"] = [_tree_nodes(self.draft.tree, flagged)]
            self.tree.update()
        self.error_box.clear()
        with self.error_box:
            for error in self.errors:
                ui.label(str(error)).classes("text-red-700 font-mono text-sm")
        if not self.errors and self.draft is not None:
            with self.error_box:
                ui.label("valid").classes("text-green-700 text-sm")
        self._mark_fields()

    def _mark_fields(self) -> None:
        """Put each error under its field, when that field is on the form."""
        for widget in self.form.descendants():
            path = widget.props.get("data-path", "")
            if path and isinstance(widget, ValidationElement):
                widget.validate()  # asks `_error_at`: the draft's error at its path, if any

    def _error_at(self, path: str) -> str | None:
        return next((e.message for e in self.errors if e.path == path), None)

    def _say(self, text: str, ok: bool) -> None:
        self.status.text = text
        self.status.classes(replace="text-sm " + ("text-green-700" if ok else "text-red-700"))


def _tree_nodes(section: Section, flagged: set[str]) -> dict[str, Any]:
    mark = " ⚠" if section.path in flagged else ""
    return {
        "id": section.path or "root",
        "label": section.name + mark,
        "children": [_tree_nodes(child, flagged) for child in section.sections],
    }


def _ancestors(path: str) -> list[str]:
    """The file ("") and every section above a field path: `a.b.c` → "", a, a.b."""
    parts = path.split(".") if path else []
    return ["", *(".".join(parts[:i]) for i in range(1, len(parts)))]


def _show(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, (list, dict)):
        return yaml.safe_dump(value, default_flow_style=True).strip()
    return str(value)
