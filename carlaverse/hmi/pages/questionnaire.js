// A questionnaire from the study runner (issue 44), shown over whatever HMI page is open.
//
// hmi.js hands every `questionnaire` frame to show(hmi, frame). One card per question, touch
// targets a finger can hit (scales and choices are rows of buttons, free text a text box).
// Each answer goes to the node as it is given, the whole set so far, so what was answered
// survives a reload of this page or a crash of the node; Submit sends the set as final once
// every required question is answered. The node's own checks decide (a refusal comes back as
// a `rejected` frame, kept in hmi.rejected); when the final set is sent the node says so
// (`submitted`), and every page of the node thanks and closes.
//
// window.hmi.questionnaire is the open one for tests and pages of your own:
// { requestId, answers, submitted }.

const THANKS_MS = 2500; // how long "Thank you" stays before the page behind comes back
const RETRY_MS = 4000; // Submit comes back if the node has not thanked by then
let open = null; // { requestId, root, answers, submit, required }

export function show(hmi, frame) {
  const request = frame.request;
  if (frame.submitted) {
    if (open && open.requestId === request.request_id) thank(hmi);
    return;
  }
  if (open && open.requestId === request.request_id) return; // already up
  close();
  open = build(hmi, request, frame.answers || {});
  hmi.questionnaire = { requestId: request.request_id, answers: open.answers, submitted: false };
}

function build(hmi, request, given) {
  stylesheet();
  const root = el(document.body, "div", "questionnaire");
  root.id = "questionnaire";
  root.dataset.request = request.request_id;
  root.setAttribute("role", "dialog");
  el(root, "h1").textContent = request.title;
  if (request.instructions) el(root, "p", "instructions").textContent = request.instructions;
  const state = { requestId: request.request_id, root, answers: { ...given }, required: [] };
  const send = (final) => hmi.send({ type: "answer", request_id: state.requestId, answers: state.answers, final });
  const changed = () => {
    send(false);
    refresh(state);
  };
  for (const item of request.items) {
    if (item.required) state.required.push(item.id);
    card(root, item, state, changed);
  }
  const footer = el(root, "div", "q-footer");
  state.left = el(footer, "p", "q-left");
  state.submit = el(footer, "button", "touch q-submit");
  state.submit.type = "button";
  state.submit.textContent = "Submit";
  state.submit.addEventListener("click", () => {
    state.submit.disabled = true; // until the node answers: no double submit
    const refusals = hmi.rejected.length;
    send(true);
    setTimeout(() => {
      if (open !== state || state.thanked) return; // thanked, or replaced
      refresh(state); // no thanks: refused or lost on the way (a reconnect), try again
      if (hmi.rejected.length > refusals) state.left.textContent = hmi.rejected.at(-1);
    }, RETRY_MS);
  });
  refresh(state);
  return state;
}

function card(root, item, state, changed) {
  const box = el(root, "fieldset", `q-item q-${item.kind}`);
  box.dataset.item = item.id;
  el(box, "legend").textContent = item.text + (item.required ? "" : " (optional)");
  if (item.kind === "text") return textBox(box, item, state, changed);
  const values = item.kind === "scale" ? range(item.low, item.high, item.step) : item.labels.map((_, i) => i);
  const perValue = item.kind === "choice" || item.labels.length === values.length;
  const row = el(box, "div", `q-options${values.length > 7 ? " q-many" : ""}`);
  const buttons = values.map((value, i) => {
    const button = el(row, "button", "q-option");
    button.type = "button";
    button.dataset.value = value;
    button.textContent = item.kind === "choice" ? item.labels[i] : String(value);
    if (item.kind === "scale" && perValue) el(button, "small").textContent = item.labels[i];
    button.addEventListener("click", () => {
      state.answers[item.id] = value;
      mark(buttons, value);
      changed();
    });
    return button;
  });
  if (item.kind === "scale" && item.labels.length === 2 && !perValue) {
    const ends = el(box, "div", "q-anchors");
    el(ends, "span").textContent = item.labels[0];
    el(ends, "span").textContent = item.labels[1];
  }
  if (item.id in state.answers) mark(buttons, state.answers[item.id]);
}

function textBox(box, item, state, changed) {
  const area = el(box, "textarea", "q-text");
  area.maxLength = item.max_chars;
  area.rows = 3;
  area.value = state.answers[item.id] ?? "";
  let timer = null;
  area.addEventListener("input", () => {
    if (area.value) state.answers[item.id] = area.value;
    else delete state.answers[item.id];
    clearTimeout(timer);
    timer = setTimeout(changed, 400); // typing: send when the finger rests, not every key
    refresh(state);
  });
}

function mark(buttons, value) {
  for (const b of buttons) b.setAttribute("aria-pressed", String(Number(b.dataset.value) === value));
}

function refresh(state) {
  const left = state.required.filter((id) => !(id in state.answers)).length;
  state.left.textContent = left ? `${left} question${left === 1 ? "" : "s"} left` : "All answered";
  state.submit.disabled = left > 0;
}

function thank(hmi) {
  const root = open.root;
  open.thanked = true;
  hmi.questionnaire = { ...hmi.questionnaire, submitted: true };
  root.replaceChildren();
  root.classList.add("q-done");
  el(root, "h1").textContent = "Thank you";
  const done = open;
  setTimeout(() => {
    if (open === done) close();
  }, THANKS_MS);
}

function close() {
  if (open) open.root.remove();
  open = null;
}

function range(low, high, step) {
  const out = [];
  for (let v = low; v <= high; v += step) out.push(v);
  return out;
}

function stylesheet() {
  if (document.getElementById("questionnaire-css")) return;
  const link = el(document.head, "link");
  link.id = "questionnaire-css";
  link.rel = "stylesheet";
  link.href = "/questionnaire.css";
}

function el(parent, tag, className) {
  const node = document.createElement(tag);
  if (className) node.className = className;
  parent.appendChild(node);
  return node;
}
