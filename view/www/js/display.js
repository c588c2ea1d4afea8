// The surgeon's display: the live picture only, no controls. A double click (or the F key) asks
// for full screen; browsers allow that only on a user's gesture, so it cannot happen on load.
import { startLiveView } from './live-view.js';
import { buildPicture } from './picture.js';

buildPicture(document.body);
startLiveView();

function toggleFullScreen() {
  if (document.fullscreenElement) document.exitFullscreen();
  else document.documentElement.requestFullscreen?.().catch(() => {});
}
document.addEventListener('dblclick', toggleFullScreen);
document.addEventListener('keydown', (e) => { if (e.key === 'f' || e.key === 'F') toggleFullScreen(); });
