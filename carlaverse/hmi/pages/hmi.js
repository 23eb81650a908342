// The HMI's page runtime: the page's layout → widgets, one WebSocket for telemetry and input.
//
//   <script type="module">
//     import { startPage } from "/hmi.js";
//     startPage("dashboard");            // layout from /api/layout/dashboard
//   </script>
//
// window.hmi exposes the live state for pages of your own and for tests: `last` (newest
// values), `drawn` (the values the widgets show), `info`, `frames`, `arrivals` (performance.now() of recent frames, ms),
// `latencies` (node state → this page, ms), `rejected` (reasons the node gave), `messages`
// (texts pushed so far), `questionnaire` (the study's open questionnaire, questionnaire.js), and
// `press(action)`, `cruise(command)`, `send(object)`, `onTelemetry(fn)`.
//
// Frames are taken as they arrive (latency, rate, `last`, listeners); the widgets draw the
// newest values once per display frame, so a busy page skips drawing, never falls behind.
//
// Latency: the node stamps each frame with its host's monotonic clock at the loop tick that
// produced the state. The page estimates the offset between that clock and performance.now()
// from ping/pong round trips (the sample with the shortest round trip wins, its half taken as
// the one-way delay), then latency = now + offset − stamp.

import { WIDGETS } from "/widgets.js";

const KEEP = 4000; // recent samples kept for rate and latency figures
const PING_BURST = 8; // quick pings at connect for a first offset
const PING_EVERY_MS = 2000;
const RECONNECT_MS = 1000;

export async function startPage(page) {
  const response = await fetch(`/api/layout/${page}`);
  const layout = await response.json();
  const hmi = new Hmi(layout);
  window.hmi = hmi;
  hmi.build(document.getElementById("layout") || document.body);
  hmi.connect();
  return hmi;
}

export class Hmi {
  constructor(layout) {
    this.layout = layout;
    this.units = layout.units || "km/h";
    this.info = null;
    this.last = null;
    this.frames = 0;
    this.arrivals = [];
    this.latencies = [];
    this.rejected = [];
    this.messages = []; // texts pushed so far
    this.offsetS = null; // node monotonic − page clock [s]
    this.bestRttMs = Infinity;
    this.widgets = [];
    this.listeners = [];
    this.socket = null;
    this.pings = 0;
    this.drawPending = false;
    this.drawn = null; // the values the widgets show now
    this.questionnaire = null; // { requestId, answers, submitted } while one is up
  }

  build(root) {
    if (this.layout.title) document.title = this.layout.title;
    this.banner = messageBanner();
    this.status = statusLine();
    root.classList.add("grid");
    root.style.gridTemplateColumns = `repeat(${this.layout.columns || 4}, 1fr)`;
    for (const place of this.layout.widgets || []) {
      const make = WIDGETS[place.widget];
      if (!make) continue;
      const cell = document.createElement("section");
      cell.className = `widget ${place.widget}`;
      cell.dataset.widget = place.widget;
      cell.style.gridColumn = `${place.column} / span ${place.width}`;
      cell.style.gridRow = `${place.row} / span ${place.height}`;
      root.appendChild(cell);
      this.widgets.push(make(cell, place, this));
    }
  }

  connect() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    const socket = new WebSocket(`${scheme}://${location.host}/ws`);
    this.socket = socket;
    socket.onopen = () => {
      this.setStatus("connected");
      this.pings = 0;
      this.ping();
    };
    socket.onmessage = (event) => this.receive(JSON.parse(event.data));
    socket.onclose = () => {
      this.setStatus("disconnected");
      setTimeout(() => this.connect(), RECONNECT_MS);
    };
  }

  receive(frame) {
    if (frame.type === "telemetry") this.telemetry(frame);
    else if (frame.type === "info") this.setInfo(frame);
    else if (frame.type === "pong") this.pong(frame);
    else if (frame.type === "message") this.showMessage(frame);
    else if (frame.type === "rejected") this.rejected.push(frame.reason);
    else if (frame.type === "questionnaire") this.showQuestionnaire(frame);
  }

  // Loaded only when the study asks one: a page without a study never fetches it.
  async showQuestionnaire(frame) {
    const { show } = await import("/questionnaire.js");
    show(this, frame);
  }

  telemetry(frame) {
    const now = performance.now();
    this.frames += 1;
    keep(this.arrivals, now);
    if (this.offsetS !== null) keep(this.latencies, (now / 1000 + this.offsetS - frame.stamp_s) * 1000);
    this.last = frame.values;
    for (const listener of this.listeners) listener(frame.values, frame);
    if (this.drawPending) return; // widgets draw the newest values once per display frame
    this.drawPending = true;
    const draw = () => {
      this.drawPending = false;
      this.drawn = this.last;
      for (const widget of this.widgets) widget.update(this.drawn);
    };
    if (document.hidden) setTimeout(draw, 0);
    else requestAnimationFrame(draw);
  }

  showMessage(message) {
    keep(this.messages, message.text);
    this.banner.show(message);
  }

  setInfo(info) {
    this.info = info;
    this.setStatus("connected");
    for (const widget of this.widgets) widget.setInfo?.(info);
  }

  ping() {
    if (!this.socket || this.socket.readyState !== WebSocket.OPEN) return;
    this.send({ type: "ping", page_ms: performance.now() });
    this.pings += 1;
    setTimeout(() => this.ping(), this.pings < PING_BURST ? 50 : PING_EVERY_MS);
  }

  pong(frame) {
    const now = performance.now();
    const rtt = now - frame.page_ms;
    if (rtt > this.bestRttMs) return;
    this.bestRttMs = rtt;
    this.offsetS = frame.node_s - (frame.page_ms + rtt / 2) / 1000;
  }

  send(message) {
    if (this.socket && this.socket.readyState === WebSocket.OPEN) this.socket.send(JSON.stringify(message));
  }

  press(action) {
    this.send({ type: "press", action });
  }

  cruise(command) {
    this.send({ type: "cruise", command });
  }

  onTelemetry(listener) {
    this.listeners.push(listener);
  }

  setStatus(state) {
    const who = this.info ? `${this.info.node_id} (${this.info.kind})` : "";
    this.status.textContent = `${who} ${state}`.trim();
    this.status.dataset.state = state;
  }

  speed(mps) {
    return Math.abs(mps) * (this.units === "mph" ? 2.2369363 : 3.6);
  }
}

function keep(list, value) {
  list.push(value);
  if (list.length > KEEP) list.splice(0, list.length - KEEP);
}

function statusLine() {
  const line = document.createElement("div");
  line.id = "hmi-status";
  line.textContent = "connecting";
  document.body.appendChild(line);
  return line;
}

// Text pushed to the HMI (HmiServer.show_message): shown on top of any page for its time.
function messageBanner() {
  const banner = document.createElement("div");
  banner.id = "hmi-messages";
  document.body.appendChild(banner);
  return {
    show(message) {
      const line = document.createElement("p");
      line.className = "message";
      line.dataset.id = message.id;
      line.textContent = message.text;
      banner.appendChild(line);
      setTimeout(() => line.remove(), message.seconds * 1000);
    },
  };
}
