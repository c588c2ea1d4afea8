// Every control of the assistant's page: the render parameter it sets (its path in the render
// parameters, docs/live-view.md), how it is shown, and its range. Ranges are the useful ones; the
// server's validation (render_params_json) has the last word and its errors appear beside them.
export const kRenderModes = ['basic', 'enhanced', 'layer-aware', 'axial-colorization', 'la-mip',
  'bscan', 'en-face'];

export const kMainControls = [
  { path: 'mode', label: 'Render mode', kind: 'select', options: kRenderModes },
  { path: 'preset', label: 'Preset', kind: 'select', options: ['retina', 'anterior'] },
  { path: 'enhanced.threshold', label: 'Threshold', kind: 'range', min: 0, max: 1, step: 0.01 },
  { path: 'enhanced.transfer.window', label: 'Intensity window', kind: 'window' },
  { path: 'enhanced.transfer.opacity', label: 'Opacity ramp', kind: 'ramp' },
  { path: 'enhanced.kg1', label: 'Edge boost (kg1)', kind: 'range', min: 0, max: 40, step: 0.5 },
  { path: 'view.light_direction', label: 'Light direction', kind: 'light' },
  { path: 'layer_aware.shadow_steps', label: 'Shadow steps (Nₛ)', kind: 'range', min: 0, max: 200,
    step: 1 },
  { path: 'processing.db_min', label: 'dB shown black', kind: 'range', min: -20, max: 80, step: 1 },
  { path: 'processing.db_max', label: 'dB shown white', kind: 'range', min: 0, max: 120, step: 1 },
  { path: 'slice.bscan', label: 'B-scan (−1: centre)', kind: 'range', min: -1, max: 127, step: 1 },
];

export const kViewControls = [
  { path: 'view.elevation_deg', label: 'Inclination (°)', kind: 'range', min: -90, max: 90, step: 1 },
  { path: 'view.azimuth_deg', label: 'Azimuth (°)', kind: 'range', min: -180, max: 180, step: 1 },
  { path: 'view.zoom', label: 'Zoom', kind: 'range', min: 0.25, max: 8, step: 0.05 },
  { path: 'view.auto_rotate', label: 'Auto-rotate (45°/s)', kind: 'toggle' },
  { path: 'view.stereo', label: 'Stereo pair', kind: 'toggle' },
  { path: 'view.stereo_angle_deg', label: 'Stereo angle (°)', kind: 'range', min: 0, max: 20,
    step: 0.5 },
];

const coefficient = (path, label, max = 4, step = 0.05) =>
  ({ path, label, kind: 'range', min: 0, max, step });

export const kAdvancedControls = [
  { path: 'enhanced.use_threshold', label: 'Threshold on', kind: 'toggle' },
  { path: 'enhanced.edge_enhancement', label: 'Edge enhancement', kind: 'toggle' },
  coefficient('enhanced.kg2', 'kg2'),
  { path: 'enhanced.feature_enhancement', label: 'Feature enhancement', kind: 'toggle' },
  coefficient('enhanced.kf1', 'kf1', 10),
  coefficient('enhanced.kf2', 'kf2'),
  { path: 'enhanced.depth_cues', label: 'Depth cues', kind: 'toggle' },
  coefficient('enhanced.kd1', 'kd1', 1, 0.01),
  coefficient('enhanced.kd2', 'kd2'),
  coefficient('enhanced.kd3', 'kd3', 1, 0.01),
  { path: 'enhanced.phong', label: 'Phong shading', kind: 'toggle' },
  coefficient('enhanced.kp1', 'kp1', 1, 0.01),
  coefficient('enhanced.kp2', 'kp2', 1, 0.01),
  coefficient('enhanced.kp3', 'kp3', 1, 0.01),
  coefficient('enhanced.kp4', 'kp4', 128, 1),
  { path: 'layer_aware.colorize', label: 'Layer colours', kind: 'toggle' },
  coefficient('layer_aware.i_min', 'Layer-aware I min', 1, 0.01),
  coefficient('layer_aware.i_max', 'Layer-aware I max', 1, 0.01),
  coefficient('layer_aware.alpha_max', 'Layer-aware α max', 1, 0.01),
  { path: 'axial.phong', label: 'Axial colorization: Phong', kind: 'toggle' },
  { path: 'axial.shadow_steps', label: 'Axial colorization: shadow steps (Nₛ, replace Phong)', kind: 'range',
    min: 0, max: 200, step: 1 },
];
