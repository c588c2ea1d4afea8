// Orbit the shared view with the pointer on the render: drag (mouse, pen or one finger) turns
// azimuth and inclination, the wheel or a two-finger pinch zooms. Changes go through onChange
// ({view: {...}}) like any control's; the camera it starts from is current().
const kDegreesPerPixel = 0.4;

export function attachOrbit(canvas, current, onChange) {
  const pointers = new Map();
  let pinchStart = null;

  canvas.addEventListener('pointerdown', (e) => {
    try {
      canvas.setPointerCapture(e.pointerId);  // keeps the drag when the pointer leaves the picture
    } catch {
      // a pointer the browser no longer tracks: the drag works without the capture
    }
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (pointers.size === 2) pinchStart = { distance: spread(pointers), zoom: current().zoom };
  });
  canvas.addEventListener('pointermove', (e) => {
    const last = pointers.get(e.pointerId);
    if (!last) return;
    const dx = e.clientX - last.x;
    const dy = e.clientY - last.y;
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (pointers.size === 1) {
      const view = current();
      const azimuth = wrap(view.azimuth_deg - dx * kDegreesPerPixel);
      const elevation = clamp(view.elevation_deg + dy * kDegreesPerPixel, -90, 90);
      onChange({ azimuth_deg: azimuth, elevation_deg: elevation });
    } else if (pointers.size === 2 && pinchStart) {
      onChange({ zoom: clamp(pinchStart.zoom * (spread(pointers) / pinchStart.distance), 0.1, 20) });
    }
  });
  const release = (e) => {
    pointers.delete(e.pointerId);
    if (pointers.size < 2) pinchStart = null;
  };
  canvas.addEventListener('pointerup', release);
  canvas.addEventListener('pointercancel', release);
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    onChange({ zoom: clamp(current().zoom * Math.exp(-e.deltaY * 0.001), 0.1, 20) });
  }, { passive: false });
}

function spread(pointers) {
  const [a, b] = [...pointers.values()];
  return Math.hypot(a.x - b.x, a.y - b.y) || 1;
}
const clamp = (x, lo, hi) => Math.min(hi, Math.max(lo, x));
const wrap = (deg) => ((((deg + 180) % 360) + 360) % 360) - 180;
