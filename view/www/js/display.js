// The surgeon's display: the live picture only, no controls.
import { startLiveView } from './live-view.js';

startLiveView();
