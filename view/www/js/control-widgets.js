// One row per control: label, input(s), the value as text, and the server's error beside it.
// build() returns {def, row, set(value), showError(text)}; onChange(value) fires on every edit.
// A control the user touched in the last second is not overwritten by the server's state.
const kUserHoldMs = 1000;

export function buildControl(def, onChange) {
  const row = document.createElement('div');
  row.className = 'control';
  row.dataset.path = def.path;
  const id = `ctl-${def.path.replaceAll('.', '-')}`;
  const label = document.createElement('label');
  label.htmlFor = id;
  label.textContent = def.label;
  const shown = document.createElement('output');
  const error = document.createElement('div');
  error.className = 'control-error';
  error.setAttribute('role', 'alert');
  const widget = kBuilders[def.kind](def, id);
  const control = {
    def,
    row,
    touchedAt: -Infinity,
    set(value) {
      if (performance.now() - control.touchedAt < kUserHoldMs || value === undefined) return;
      widget.set(value);
      shown.textContent = widget.text();
    },
    showError(text) {
      error.textContent = text || '';
      row.classList.toggle('refused', Boolean(text));
    },
  };
  widget.listen(() => {
    control.touchedAt = performance.now();
    shown.textContent = widget.text();
    onChange(widget.get());
  });
  row.append(label, widget.element, shown, error);
  return control;
}

function input(type, id, attributes = {}) {
  const e = document.createElement('input');
  e.type = type;
  if (id) e.id = id;
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  return e;
}

function group(...children) {
  const g = document.createElement('span');
  g.className = 'control-inputs';
  g.append(...children);
  return g;
}

const round = (x) => Math.round(x * 1000) / 1000;

const kBuilders = {
  select(def, id) {
    const e = document.createElement('select');
    e.id = id;
    for (const option of def.options) e.add(new Option(option, option));
    return { element: e, get: () => e.value, set: (v) => { e.value = v; }, text: () => '',
      listen: (f) => e.addEventListener('change', f) };
  },
  toggle(def, id) {
    const e = input('checkbox', id);
    return { element: e, get: () => e.checked, set: (v) => { e.checked = Boolean(v); },
      text: () => (e.checked ? 'on' : 'off'), listen: (f) => e.addEventListener('change', f) };
  },
  range(def, id) {
    const e = input('range', id, { min: def.min, max: def.max, step: def.step });
    const integer = Number.isInteger(def.step);
    return { element: e, get: () => (integer ? parseInt(e.value, 10) : Number(e.value)),
      set: (v) => { e.value = v; }, text: () => e.value,
      listen: (f) => e.addEventListener('input', f) };
  },
  // [low, high] of the intensity window.
  window(def, id) {
    const low = input('range', id, { min: 0, max: 1, step: 0.01, 'aria-label': 'window low' });
    const high = input('range', `${id}-high`, { min: 0, max: 1, step: 0.01, 'aria-label': 'window high' });
    return { element: group(low, high), get: () => [Number(low.value), Number(high.value)],
      set: (v) => { low.value = v[0]; high.value = v[1]; }, text: () => `${low.value}–${high.value}`,
      listen: (f) => { low.addEventListener('input', f); high.addEventListener('input', f); } };
  },
  // The opacity ramp [[0, 0], [knee, alpha at knee], [1, alpha at 1]].
  ramp(def, id) {
    const knee = input('range', id, { min: 0.01, max: 0.99, step: 0.01, 'aria-label': 'ramp knee' });
    const kneeAlpha = input('range', `${id}-knee-alpha`, { min: 0, max: 1, step: 0.01, 'aria-label': 'opacity at knee' });
    const topAlpha = input('range', `${id}-top-alpha`, { min: 0, max: 1, step: 0.01, 'aria-label': 'opacity at 1' });
    return { element: group(knee, kneeAlpha, topAlpha),
      get: () => [[0, 0], [Number(knee.value), Number(kneeAlpha.value)], [1, Number(topAlpha.value)]],
      set: (v) => {
        if (!Array.isArray(v) || v.length < 3) return;
        knee.value = v[1][0]; kneeAlpha.value = v[1][1]; topAlpha.value = v[v.length - 1][1];
      },
      text: () => `knee ${knee.value}: ${kneeAlpha.value} → ${topAlpha.value}`,
      listen: (f) => [knee, kneeAlpha, topAlpha].forEach((e) => e.addEventListener('input', f)) };
  },
  // The light's direction in camera space, as azimuth and elevation in degrees.
  light(def, id) {
    const az = input('range', id, { min: -180, max: 180, step: 1, 'aria-label': 'light azimuth' });
    const el = input('range', `${id}-elevation`, { min: -90, max: 90, step: 1, 'aria-label': 'light elevation' });
    const rad = Math.PI / 180;
    return { element: group(az, el),
      get: () => {
        const a = Number(az.value) * rad;
        const e = Number(el.value) * rad;
        return [round(Math.cos(e) * Math.sin(a)), round(Math.sin(e)), round(Math.cos(e) * Math.cos(a))];
      },
      set: (v) => {
        const n = Math.hypot(...v) || 1;
        el.value = Math.round(Math.asin(v[1] / n) / rad);
        az.value = Math.round(Math.atan2(v[0], v[2]) / rad);
      },
      text: () => `${az.value}°, ${el.value}°`,
      listen: (f) => { az.addEventListener('input', f); el.addEventListener('input', f); } };
  },
};
