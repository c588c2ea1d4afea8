// Where the current B-scan lies in the volume: the en face field as an outline, every B-scan
// position as a faint line, the current one as a bright bar, and "B-scan i of n" beneath; the
// instrument's tip as a dot where it is (`tip`: fractions of the field, instrument-readout.js).
export function drawBscanLocator(canvas, label, bscanIndex, bscans, tip = null) {
  const ctx = canvas.getContext('2d');
  const { width, height } = canvas;
  ctx.clearRect(0, 0, width, height);
  const pad = 6;
  const w = width - 2 * pad;
  const h = height - 2 * pad;
  ctx.strokeStyle = '#8aa';
  ctx.lineWidth = 2;
  ctx.strokeRect(pad, pad, w, h);
  if (!(bscans > 0) || !(bscanIndex >= 0)) {
    label.textContent = 'B-scan position unknown';
    return;
  }
  ctx.strokeStyle = 'rgba(140, 170, 170, 0.25)';
  ctx.lineWidth = 1;
  const step = Math.max(1, Math.ceil(bscans / 32));
  for (let i = 0; i < bscans; i += step) {
    const y = pad + ((i + 0.5) / bscans) * h;
    ctx.beginPath();
    ctx.moveTo(pad, y);
    ctx.lineTo(pad + w, y);
    ctx.stroke();
  }
  const y = pad + ((bscanIndex + 0.5) / bscans) * h;
  ctx.strokeStyle = '#ffd24a';
  ctx.lineWidth = Math.max(3, h / bscans);
  ctx.beginPath();
  ctx.moveTo(pad, y);
  ctx.lineTo(pad + w, y);
  ctx.stroke();
  if (tip) {
    ctx.fillStyle = tip.colour;
    ctx.beginPath();
    ctx.arc(pad + tip.x * w, pad + tip.y * h, Math.max(4, Math.min(w, h) / 20), 0, 2 * Math.PI);
    ctx.fill();
  }
  label.textContent = `B-scan ${bscanIndex + 1} of ${bscans}`;
}
