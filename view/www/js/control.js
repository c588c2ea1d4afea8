// The assistant's page: the live picture with every control. Each edit goes to the server
// (throttled, ParamSender); a refusal's text appears beside the control that caused it; the
// controls follow the shared parameters the server reports, except the one being touched.
import { startLiveView } from './live-view.js';
import { tokenFromFragment } from './token.js';
import { ParamSender } from './param-sender.js';
import { getPath } from './param-paths.js';
import { buildControl } from './control-widgets.js';
import { kMainControls, kViewControls, kAdvancedControls } from './control-table.js';
import { attachOrbit } from './orbit.js';
import { attachPresets } from './presets-panel.js';
import { buildPicture } from './picture.js';

const $ = (id) => document.getElementById(id);
const token = tokenFromFragment();
const controls = [];
let params = {};
let role = 'viewer';
// A viewer (no token) who drags the picture orbits a camera of its own, rendered for it alone;
// "Follow" goes back to the shared view.
let ownView = null;

buildPicture($('live'), { interactive: true });
// Enter in a field must not submit the form (a reload); an inline handler would be refused by the
// page's Content-Security-Policy, so the module says it.
$('controls').addEventListener('submit', (e) => e.preventDefault());
const live = startLiveView({
  token,
  onState: (state) => {
    role = state.role === 'operator' ? 'operator' : 'viewer';
    $('role').textContent = role === 'operator'
      ? 'Operator'
      : 'Viewer — drag the picture to orbit your own view; other changes need the operator\u2019s link';
    $('role').className = role;
    $('follow').hidden = role === 'operator' || ownView === null;
    if (state.params) {
      params = state.params;
      for (const control of controls) control.set(getPath(params, control.def.path));
    }
  },
  onFrame: (meta) => {
    const bscan = controls.find((c) => c.def.path === 'slice.bscan');
    if (bscan && meta.bscans > 0) bscan.row.querySelector('input').max = meta.bscans - 1;
  },
  // The viewer's own camera is gone with ioct-gpu's connection: the shared view again, said so.
  onOwnViewClosed: (reason) => {
    ownView = null;
    $('follow').hidden = true;
    $('general-error').textContent = `Your own view was closed: ${reason}. Showing the shared view.`;
  },
});

const sender = new ParamSender(live.socket, {
  onReply: (reply, paths) => {
    if (reply.ok) {
      for (const control of controls) if (paths.includes(control.def.path)) control.showError('');
      $('general-error').textContent = '';
      return;
    }
    const key = String(reply.key || '').replace(/^render\./, '');
    const culprit = controls.find((c) => key === c.def.path)
      || controls.find((c) => key.startsWith(`${c.def.path}[`) || key.startsWith(`${c.def.path}.`))
      || controls.find((c) => paths.includes(c.def.path));
    if (culprit) culprit.showError(reply.error || 'refused');
    else $('general-error').textContent = reply.error || 'refused';
  },
});

function addControls(container, table) {
  for (const def of table) {
    const control = buildControl(def, (value) => sender.change(def.path, value));
    controls.push(control);
    container.append(control.row);
  }
}
addControls($('main-controls'), kMainControls);
addControls($('view-controls'), kViewControls);
addControls($('advanced-controls'), kAdvancedControls);

const ownSender = new ParamSender(live.socket, {
  type: 'own_view',
  onReply: (reply) => {
    $('general-error').textContent = reply.ok ? '' : (reply.error || 'refused');
  },
});

attachOrbit($('render'),
  () => ({ azimuth_deg: 30, elevation_deg: 25, zoom: 1, ...(params.view || {}), ...(ownView || {}) }),
  (viewChanges) => {
    if (role !== 'operator') {
      ownView = { ...(ownView || params.view || {}), ...viewChanges, auto_rotate: false };
      for (const [key, value] of Object.entries(viewChanges)) ownSender.change(`view.${key}`, value);
      ownSender.change('view.auto_rotate', false);
      $('follow').hidden = false;
      return;
    }
    params.view = { ...(params.view || {}), ...viewChanges };
    for (const [key, value] of Object.entries(viewChanges)) sender.change(`view.${key}`, value);
  });

$('follow').addEventListener('click', () => {
  ownView = null;
  $('follow').hidden = true;
  live.socket.send({ type: 'follow' });
});

async function act(button, message, describe) {
  const reply = await live.socket.request(message);
  $(`${button}-result`).textContent = reply.ok ? describe(reply) : (reply.error || 'refused');
  $(`${button}-result`).className = reply.ok ? 'result' : 'result control-error';
}
$('scan-start').addEventListener('click', () => act('scan', { type: 'scan', cmd: 'start' }, (r) => `start: ${r.state || 'ok'}`));
$('scan-stop').addEventListener('click', () => act('scan', { type: 'scan', cmd: 'stop' }, (r) => `stop: ${r.state || 'ok'}`));
$('snapshot').addEventListener('click', () => act('snapshot', { type: 'snapshot' }, (r) => `saved ${r.png || ''}`));

attachPresets({ list: $('preset-list'), nameInput: $('preset-name'), saveButton: $('preset-save'),
  errorElement: $('preset-error') }, token);

window.ioctControl = { controls, sender };
