// The one line that says what the appliance is doing: scanning / stopped / fault, laser on/off,
// groups per second, drops. Reads ioct-view's state message; `rt` is ioct-rt's status object
// ({safety: {state, emission_readback, faults}, acquisition: {replay_error}, ...}), or null with
// the reason in `rt_error`; `rt_age_ms` its age: an old one is not shown as the scanner's or the
// laser's state.

// ioct-rt's status older than this (ioct-view polls it every 100 ms; a poll waits behind the
// operators' commands) no longer says what the scanner and the laser are doing now.
export const kRtStatusOldMs = 1000;

export function describeState(state) {
  const rt = state.rt && typeof state.rt === 'object' ? (state.rt.status || state.rt) : null;
  const old = Number.isFinite(state.rt_age_ms) && state.rt_age_ms > kRtStatusOldMs;
  const safety = rt && rt.safety && !old ? rt.safety : null;
  let scan = 'scanner unknown';
  let scanClass = 'unknown';
  if (old) {
    scan = `scanner: its last status is ${(state.rt_age_ms / 1000).toFixed(1)} s old`;
  } else if (safety) {
    const s = safety.state;
    if (s === 'scanning') [scan, scanClass] = ['SCANNING', 'ok'];
    else if (s === 'fault') [scan, scanClass] = [`FAULT${safety.faults ? `: ${safety.faults}` : ''}`, 'fault'];
    else if (s === 'arming') [scan, scanClass] = ['ARMING', 'warn'];
    else [scan, scanClass] = ['STOPPED', 'warn'];
    // A replay that met a group it could not read ends like a lost digitizer: say which and why.
    const replayError = rt.acquisition && typeof rt.acquisition.replay_error === 'string'
      ? rt.acquisition.replay_error : '';
    if (replayError && s !== 'scanning' && s !== 'arming') {
      scan += ` — the replay stopped: ${replayError}`;
    }
  } else if (state.rt_error) {
    scan = `scanner: ${state.rt_error}`;
  } else if (typeof state.rt === 'string') {
    scan = `scanner: ${state.rt}`;
  } else if (rt && rt.error) {
    scan = `scanner: ${rt.error}`;
  }
  const laser = safety ? (safety.emission_readback ? 'LASER ON' : 'laser off') : 'laser ?';
  const rate = Number.isFinite(state.groups_per_s) ? `${state.groups_per_s.toFixed(1)} groups/s` : '– groups/s';
  const drops = Number.isFinite(state.dropped) ? `${state.dropped} dropped` : '';
  return { scan, scanClass, laser, laserOn: Boolean(safety && safety.emission_readback), rate, drops };
}

export function renderStateLine(element, state) {
  const d = describeState(state);
  element.replaceChildren(
    span(d.scan, `scan ${d.scanClass}`),
    span(d.laser, d.laserOn ? 'laser on' : 'laser'),
    span(d.rate, 'rate'),
    span(d.drops, 'drops'));
}

function span(text, className) {
  const s = document.createElement('span');
  s.className = className;
  s.textContent = text;
  return s;
}
