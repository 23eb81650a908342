// The HMI's widgets. Each is make(cell, place, hmi) → { update(values), setInfo?(info) };
// the layout (configs/hmi/*.yaml) says which widgets a page has and where.
//
// Telemetry values (drive): speed_mps, rpm, gear, indicator, blink_on, lights (LIGHT_* bits),
// adas_active, cruise_active, cruise_speed_mps, warnings; (bike): speed_mps, power_w, cadence_rpm,
// grade_percent, warnings. Readouts carry data-readout="<name>" so a test can read them.

const LIGHT = { parking: 0x01, low_beam: 0x02, high_beam: 0x04, fog: 0x08, brake: 0x10, reverse: 0x20, interior: 0x40 };
const SVG = "http://www.w3.org/2000/svg";
const SWEEP_DEG = 240; // a gauge's needle travel

export const WIDGETS = {
  speedometer: (cell, place, hmi) => {
    const [top, step] = hmi.units === "mph" ? [160, 10] : [260, 20];
    const gauge = dial(cell, place.label || "speed", top, step, hmi.units, "speed");
    return { update: (v) => gauge.set(hmi.speed(v.speed_mps), Math.round(hmi.speed(v.speed_mps))) };
  },
  tachometer: (cell, place) => {
    let gauge = dial(cell, place.label || "engine", 8, 1, "rpm (dial ×1000)", "rpm", 6.5);
    return {
      setInfo(info) {
        const redline = (info.static.redline_rpm || 6500) / 1000;
        cell.replaceChildren();
        gauge = dial(cell, place.label || "engine", Math.ceil(redline + 1), 1, "rpm (dial ×1000)", "rpm", redline);
      },
      update: (v) => gauge.set(v.rpm / 1000, Math.round(v.rpm)),
    };
  },
  gear: (cell, place, hmi) => {
    const out = readout(cell, place.label || "gear", "gear", "");
    return { update: (v) => (out.textContent = gearName(v.gear, hmi.info)) };
  },
  indicators: (cell, place) => {
    title(cell, place.label || "indicators");
    const row = el(cell, "div", "lamps");
    const left = lamp(row, "◀", "indicator-left");
    const hazard = lamp(row, "⚠", "hazard");
    const right = lamp(row, "▶", "indicator-right");
    return {
      update(v) {
        const blink = Boolean(v.blink_on);
        const side = v.indicator;
        setLit(left, blink && (side === "left" || side === "hazard"));
        setLit(right, blink && (side === "right" || side === "hazard"));
        setLit(hazard, side === "hazard");
      },
    };
  },
  lights: (cell, place) => {
    title(cell, place.label || "lights");
    const row = el(cell, "div", "lamps");
    const lamps = ["parking", "low_beam", "high_beam", "fog", "brake", "reverse"].map((name) => [
      name,
      lamp(row, name.replace("_", " "), `light-${name}`),
    ]);
    return { update: (v) => lamps.forEach(([name, node]) => setLit(node, (v.lights & LIGHT[name]) !== 0)) };
  },
  adas: (cell, place, hmi) => {
    title(cell, place.label || "cruise · ADAS");
    const cruise = el(cell, "div", "big");
    cruise.dataset.readout = "cruise";
    const adas = el(cell, "div", "small");
    adas.dataset.readout = "adas";
    return {
      update(v) {
        cruise.textContent = v.cruise_active ? `CRUISE ${Math.round(hmi.speed(v.cruise_speed_mps))} ${hmi.units}` : "cruise off";
        setLit(cruise, Boolean(v.cruise_active));
        cruise.classList.toggle("off", !v.cruise_active);
        adas.textContent = v.adas_active ? "ADAS override active" : "driver alone";
      },
    };
  },
  warnings: (cell, place) => {
    title(cell, place.label || "warnings");
    const list = el(cell, "ul", "warnings-list");
    list.dataset.readout = "warnings";
    return {
      update(v) {
        const text = (v.warnings || []).join("|");
        if (list.dataset.text === text) return;
        list.dataset.text = text;
        list.replaceChildren(...(v.warnings || []).map((w) => Object.assign(document.createElement("li"), { textContent: w })));
      },
    };
  },
  speed: (cell, place, hmi) => number(cell, place.label || "speed", "speed", hmi.units, (v) => hmi.speed(v.speed_mps), 0),
  power: (cell, place) => number(cell, place.label || "power", "power", "W", (v) => v.power_w, 0, 600),
  cadence: (cell, place) => number(cell, place.label || "cadence", "cadence", "rpm", (v) => v.cadence_rpm, 0, 150),
  grade: (cell, place) => number(cell, place.label || "grade", "grade", "%", (v) => v.grade_percent, 1),
  lights_panel: (cell, place, hmi) =>
    panel(cell, place.label || "lights", hmi, [
      ["low_beam", "Low beam", (v) => (v.lights & LIGHT.low_beam) !== 0],
      ["high_beam", "High beam", (v) => (v.lights & LIGHT.high_beam) !== 0],
      ["fog", "Fog", (v) => (v.lights & LIGHT.fog) !== 0],
      ["interior", "Interior", (v) => (v.lights & LIGHT.interior) !== 0],
    ]),
  gear_panel: (cell, place, hmi) =>
    panel(cell, place.label || "gear", hmi, [
      ["gear_reverse", "R", (v) => v.gear < 0],
      ["gear_neutral", "N", (v) => v.gear === 0],
      ["gear_drive", "D", (v) => v.gear > 0],
      ["gear_down", "−", () => false],
      ["gear_up", "+", () => false],
    ]),
  indicator_panel: (cell, place, hmi) =>
    panel(cell, place.label || "indicators", hmi, [
      ["indicator_left", "◀ Left", (v) => v.indicator === "left"],
      ["hazard", "⚠ Hazard", (v) => v.indicator === "hazard"],
      ["indicator_right", "Right ▶", (v) => v.indicator === "right"],
    ]),
  cruise_panel: (cell, place, hmi) => {
    const buttons = panel(cell, place.label || "cruise", hmi, [
      ["set", "Set", (v) => Boolean(v.cruise_active)],
      ["resume", "Resume", () => false],
      ["cancel", "Cancel", () => false],
    ], (command) => hmi.cruise(command), (info) => info.cruise);
    const state = el(cell, "div", "small");
    state.dataset.readout = "cruise";
    return {
      setInfo: buttons.setInfo,
      update(v) {
        buttons.update(v);
        state.textContent = v.cruise_active ? `holding ${Math.round(hmi.speed(v.cruise_speed_mps))} ${hmi.units}` : "off";
      },
    };
  },
};

function el(parent, tag, className) {
  const node = document.createElement(tag);
  if (className) node.className = className;
  parent.appendChild(node);
  return node;
}

function title(cell, text) {
  el(cell, "h2").textContent = text;
}

function readout(cell, label, name, unit) {
  title(cell, label);
  const value = el(cell, "div", "big");
  value.dataset.readout = name;
  if (unit) el(cell, "div", "unit").textContent = unit;
  return value;
}

function lamp(row, text, name) {
  const node = el(row, "span", "lamp");
  node.textContent = text;
  node.dataset.lamp = name;
  return node;
}

function setLit(node, on) {
  node.classList.toggle("on", on);
}

function gearName(gear, info) {
  if (gear < 0) return "R";
  if (gear === 0) return "N";
  return info && info.static.transmission === "automatic" ? `D${gear}` : String(gear);
}

// A number with its unit and, when `top` is given, a bar from 0 to top.
function number(cell, label, name, unit, pick, digits, top) {
  const out = readout(cell, label, name, unit);
  const bar = top ? el(el(cell, "div", "bar"), "div", "fill") : null;
  return {
    update(v) {
      const value = pick(v);
      out.textContent = value.toFixed(digits);
      if (bar) bar.style.width = `${Math.max(0, Math.min(100, (100 * value) / top))}%`;
    },
  };
}

// Touch buttons sending `press` (or a custom `send`); lit while `isOn(values)` holds, enabled
// when the node takes them.
function panel(cell, label, hmi, buttons, send = (action) => hmi.press(action), takes = null) {
  title(cell, label);
  const row = el(cell, "div", "buttons");
  const made = buttons.map(([action, text, isOn]) => {
    const button = el(row, "button", "touch");
    button.textContent = text;
    button.dataset.action = action;
    button.addEventListener("click", () => send(action));
    return [action, button, isOn];
  });
  return {
    setInfo(info) {
      for (const [action, button] of made) button.disabled = !(takes ? takes(info) : info.actions.includes(action));
    },
    update: (v) => made.forEach(([, button, isOn]) => setLit(button, isOn(v))),
  };
}

// A round gauge: 0..top with a tick every `step`, a red zone from `red`, a needle and readout.
function dial(cell, label, top, step, unit, name, red) {
  title(cell, label);
  const svg = document.createElementNS(SVG, "svg");
  svg.setAttribute("viewBox", "-110 -110 220 190");
  svg.classList.add("dial");
  cell.appendChild(svg);
  const angle = (value) => ((-SWEEP_DEG / 2 + (SWEEP_DEG * Math.max(0, Math.min(top, value))) / top) * Math.PI) / 180;
  const at = (value, r) => [r * Math.sin(angle(value)), -r * Math.cos(angle(value))];
  svg.appendChild(arc(0, top, top, 96, "track", at));
  if (red !== undefined && red < top) svg.appendChild(arc(red, top, top, 96, "red", at));
  const labelEvery = top / step > 10 ? 2 : 1; // a label on every tick would crowd the dial
  for (let i = 0; i * step <= top + 1e-9; i += 1) {
    const v = i * step;
    const [x1, y1] = at(v, 86);
    const [x2, y2] = at(v, 96);
    svg.appendChild(shape("line", { x1, y1, x2, y2, class: "tick" }));
    if (i % labelEvery) continue;
    const [tx, ty] = at(v, 72);
    const text = shape("text", { x: tx, y: ty + 4, class: "tick-label" });
    text.textContent = Math.round(v);
    svg.appendChild(text);
  }
  const needle = shape("line", { x1: 0, y1: 0, x2: 0, y2: -80, class: "needle" });
  svg.appendChild(needle);
  svg.appendChild(shape("circle", { cx: 0, cy: 0, r: 6, class: "hub" }));
  const value = shape("text", { x: 0, y: 45, class: "dial-value" });
  value.dataset.readout = name;
  svg.appendChild(value);
  const units = shape("text", { x: 0, y: 64, class: "dial-unit" });
  units.textContent = unit;
  svg.appendChild(units);
  return {
    set(gaugeValue, shown) {
      const deg = (angle(gaugeValue) * 180) / Math.PI;
      needle.setAttribute("transform", `rotate(${deg.toFixed(2)})`);
      value.textContent = String(shown);
    },
  };
}

function arc(from, to, top, r, className, at) {
  const [x1, y1] = at(from, r);
  const [x2, y2] = at(to, r);
  const large = ((to - from) / top) * SWEEP_DEG > 180 ? 1 : 0;
  return shape("path", { d: `M ${x1} ${y1} A ${r} ${r} 0 ${large} 1 ${x2} ${y2}`, class: className });
}

function shape(tag, attributes) {
  const node = document.createElementNS(SVG, tag);
  for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, value);
  return node;
}
