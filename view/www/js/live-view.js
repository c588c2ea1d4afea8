// The live picture, shared by the surgeon's display and the assistant's page: connects, draws
// each frame, marks the B-scan's position, keeps the state line current, and greys everything
// out under a STALE / NO SIGNAL banner whenever the picture is not known to be live.
// window.ioctView exposes what the page knows (for the operator's page and for tests).
import { LiveSocket } from './live-socket.js';
import { FramePainter } from './frame-painter.js';
import { SignalWatch, formatAge } from './signal-watch.js';
import { drawBscanLocator } from './bscan-locator.js';
import { renderInstrumentReadout, tipOnLocator } from './instrument-readout.js';
import { renderStateLine } from './state-line.js';

const kBannerCheckMs = 100;

export function startLiveView({ token = '', onState = () => {}, onFrame = () => {},
                                onOwnViewClosed = () => {} } = {}) {
  const $ = (id) => document.getElementById(id);
  const elements = {
    picture: $('picture'),
    render: $('render'),
    bscan: $('bscan'),
    locator: $('bscan-locator'),
    locatorLabel: $('bscan-locator-label'),
    instrument: $('instrument-readout'),
    tipBscans: $('tip-bscans'),
    stateLine: $('state-line'),
    banner: $('signal-banner'),
    bannerTitle: $('signal-banner-title'),
    bannerDetail: $('signal-banner-detail'),
    problem: $('page-problem'),
  };
  const status = {
    framesReceived: 0,
    framesDrawn: 0,
    lastFrame: null,    // the newest drawn frame's description
    lastState: null,
    signal: 'no_signal',
    role: 'viewer',
    connected: false,
    problems: [],
  };
  const watch = new SignalWatch();
  const reportProblem = (text) => {
    status.problems.push(text);
    if (elements.problem) elements.problem.textContent = text;
  };

  let socket = null;
  const painter = new FramePainter({
    renderCanvas: elements.render,
    bscanCanvas: elements.bscan,
    tipCanvas: elements.tipBscans,
    onProblem: reportProblem,
    onDrawn: (meta) => {
      status.framesDrawn += 1;
      status.lastFrame = meta;
      watch.pictureDrawn(meta.age_ms, meta.receivedAt);
      updateBanner();
      status.tipMarked = painter.tipMarked;
      status.tipOnRender = painter.tipOnRender;
      socket.send({ type: 'drawn', frame: meta.frame, view: meta.view });
      document.body.classList.toggle('stereo', Boolean(meta.stereo));
      if (elements.locator) {
        drawBscanLocator(elements.locator, elements.locatorLabel, meta.bscan_index, meta.bscans,
          tipOnLocator(meta));
      }
      renderInstrumentReadout(elements.instrument, meta.instrument);
      onFrame(meta);
    },
  });

  socket = new LiveSocket({
    token,
    onOpen: () => { status.connected = true; watch.connection(true); updateBanner(); },
    onClose: (reason) => {
      status.connected = false;
      watch.connection(false);
      elements.stateLine.textContent = `Not connected: ${reason}. Reconnecting…`;
      updateBanner();
    },
    onFrame: (frame) => {
      status.framesReceived += 1;
      watch.frame();
      frame.meta.receivedAt = performance.now();
      painter.paint(frame);
    },
    onState: (state) => {
      status.lastState = state;
      status.role = state.role || 'viewer';
      watch.state(state);
      renderStateLine(elements.stateLine, state);
      updateBanner();
      onState(state);
    },
    onProblem: reportProblem,
    onOwnViewClosed,
    // The surgeon's foot: the B-scan panel is the page's own to show or hide; the other actions
    // ioct-view carries out, and the next frames show them.
    onFootswitch: (action) => {
      status.footswitchPresses = (status.footswitchPresses || 0) + 1;
      if (action === 'toggle-bscan') document.body.classList.toggle('bscan-hidden');
    },
  });

  function updateBanner() {
    const { signal, ageMs, reason } = watch.current();
    status.signal = signal;
    const live = signal === 'live';
    elements.picture.classList.toggle('not-live', !live);
    elements.banner.hidden = live;
    if (!live) {
      elements.bannerTitle.textContent = signal === 'stale' ? 'STALE' : 'NO SIGNAL';
      const age = formatAge(ageMs);
      elements.bannerDetail.textContent = age ? `${reason} — newest scan ${age} old` : reason;
    }
  }

  setInterval(updateBanner, kBannerCheckMs);
  updateBanner();
  socket.connect();
  window.ioctView = { status, socket };
  return { status, socket };
}
