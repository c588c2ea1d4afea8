// The instrument the frame shows (its description's `instrument`): the tip's signed distances to
// the RPE and the ILM as large type over the render, and the tip's marker on the B-scan and on the
// B-scan locator. A measured distance, an inferred one (the surfaces carried in from beside the
// tool's shadow) and "no instrument" look different; within the warning distance of the RPE the
// readout turns red. Distances are positive above the surface, negative below it.
export function describeInstrument(instrument) {
  if (!instrument || instrument.state === 'off' || !instrument.state) return { shown: false };
  if (instrument.state === 'none') {
    return { shown: true, kind: 'none', title: 'No instrument', lines: [] };
  }
  const inferred = instrument.distance === 'inferred';
  const known = instrument.distance === 'measured' || inferred;
  const lines = known
    ? [distanceLine('RPE', instrument.to_rpe_um, inferred), distanceLine('ILM', instrument.to_ilm_um, inferred)]
    : ['retina not segmented at the tip'];
  let title = inferred ? 'Tip (inferred under the tool)' : 'Tip';
  if (instrument.warning) title = `TIP WITHIN ${Math.round(instrument.warn_rpe_um)} µm OF THE RPE`;
  return {
    shown: true,
    kind: instrument.warning ? 'warning' : inferred ? 'inferred' : known ? 'measured' : 'unknown',
    title,
    lines,
  };
}

function distanceLine(surface, um, inferred) {
  if (!Number.isFinite(um)) return `${surface}: unknown`;
  const side = um >= 0 ? 'above' : 'below';
  return `${surface} ${inferred ? '≈ ' : ''}${Math.round(Math.abs(um))} µm ${side}`;
}

export function renderInstrumentReadout(element, instrument) {
  if (!element) return;
  const d = describeInstrument(instrument);
  element.hidden = !d.shown;
  if (!d.shown) return;
  element.className = d.kind;
  const title = document.createElement('div');
  title.className = 'title';
  title.textContent = d.title;
  const lines = d.lines.map((text) => {
    const line = document.createElement('div');
    line.className = 'distance';
    line.textContent = text;
    return line;
  });
  element.replaceChildren(title, ...lines);
}

// The tip on the B-scan just drawn, when the tip lies in it (within 1.5 B-scans): a ring with a
// cross, solid for a measured distance, dashed for an inferred one, red when warning.
export function drawTipMarker(canvas, meta) {
  const tip = tipOf(meta);
  if (!tip || !(meta.bscan_width > 0) || !(meta.bscan_height > 0)) return false;
  if (Math.abs(tip.bscan - meta.bscan_index) > 1.5) return false;
  const x = ((tip.ascan + 0.5) / meta.bscan_width) * canvas.width;
  const y = ((tip.depth + 0.5) / meta.bscan_height) * canvas.height;
  ring(canvas, meta.instrument, x, y, Math.max(8, canvas.width / 40));
  return true;
}

// The tip over the render just drawn, where ioct-gpu placed it in each eye's image (render_xy,
// output px; null where it is not in the picture or the mode is planar).
export function drawRenderTipMarker(canvas, meta) {
  if (!tipOf(meta) || !Array.isArray(meta.instrument.render_xy) || !(meta.width > 0)) return false;
  const scale = canvas.width / meta.width;
  let drawn = false;
  for (const point of meta.instrument.render_xy) {
    if (!Array.isArray(point) || !point.every(Number.isFinite)) continue;
    ring(canvas, meta.instrument, point[0] * scale, point[1] * scale,
      Math.max(5, canvas.width / (meta.stereo ? 180 : 90)));
    drawn = true;
  }
  return drawn;
}

function ring(canvas, instrument, x, y, r) {
  const ctx = canvas.getContext('2d');
  ctx.save();
  ctx.lineWidth = Math.max(2, r / 4);
  ctx.strokeStyle = markerColour(instrument);
  ctx.setLineDash(instrument.distance === 'inferred' ? [r / 2, r / 3] : []);
  ctx.beginPath();
  ctx.arc(x, y, r, 0, 2 * Math.PI);
  ctx.stroke();
  ctx.setLineDash([]);
  ctx.beginPath();
  ctx.moveTo(x - 1.8 * r, y);
  ctx.lineTo(x - 1.2 * r, y);
  ctx.moveTo(x + 1.2 * r, y);
  ctx.lineTo(x + 1.8 * r, y);
  ctx.moveTo(x, y - 1.8 * r);
  ctx.lineTo(x, y - 1.2 * r);
  ctx.stroke();
  ctx.restore();
}

// The B-scan pair through the tip (along | across the instrument, side by side, the tip in each
// half's centre column): a marker at the tip in each half.
export function drawTipBscanMarkers(canvas, meta) {
  const tip = tipOf(meta);
  const w = meta.tip_bscan_width, h = meta.tip_bscan_height;
  if (!tip || !(w > 0) || !(h > 0)) return false;
  const sx = canvas.width / (2 * w), sy = canvas.height / h;
  const r = Math.max(6, canvas.width / 60);
  for (const half of [0, 1]) {
    ring(canvas, meta.instrument, (half * w + Math.floor(w / 2) + 0.5) * sx, (tip.depth + 0.5) * sy, r);
  }
  const ctx = canvas.getContext('2d');
  ctx.save();
  // The seam between the two B-scans.
  ctx.strokeStyle = 'rgba(140, 170, 170, 0.6)';
  ctx.beginPath();
  ctx.moveTo(canvas.width / 2, 0);
  ctx.lineTo(canvas.width / 2, canvas.height);
  ctx.stroke();
  ctx.restore();
  return true;
}

// Where the tip lies en face, for the B-scan locator: fractions of the field across the A-scans
// (x) and the B-scans (y), or null.
export function tipOnLocator(meta) {
  const tip = tipOf(meta);
  if (!tip || !(meta.bscan_width > 0) || !(meta.bscans > 0)) return null;
  return {
    x: (tip.ascan + 0.5) / meta.bscan_width,
    y: (tip.bscan + 0.5) / meta.bscans,
    colour: markerColour(meta.instrument),
  };
}

function tipOf(meta) {
  const instrument = meta && meta.instrument;
  if (!instrument || instrument.state !== 'found' || !Array.isArray(instrument.tip_voxel)) return null;
  const [bscan, ascan, depth] = instrument.tip_voxel;
  if (![bscan, ascan, depth].every(Number.isFinite)) return null;
  return { bscan, ascan, depth };
}

function markerColour(instrument) {
  if (instrument.warning) return '#ff5a5a';
  return instrument.distance === 'measured' ? '#5be08a' : '#ffb547';
}
