// Sends render-parameter changes at most once per interval (30 ms): changes made meanwhile are
// merged and go out together with the next message, so a dragged slider never floods the server.
// Each message's reply goes to onReply(reply, paths) with the paths it carried. `type` is the
// message's: 'params' (the shared view, operators) or 'own_view' (a viewer's own camera).
import { leafPaths, setPath } from './param-paths.js';

export class ParamSender {
  constructor(socket, { intervalMs = 30, onReply = () => {}, type = 'params' } = {}) {
    Object.assign(this, { socket, intervalMs, onReply, type });
    this.pending = null;
    this.lastSentAt = -Infinity;
    this.timer = null;
  }

  change(path, value) {
    this.pending = setPath(this.pending || {}, path, value);
    if (this.timer !== null) return;
    const wait = Math.max(0, this.lastSentAt + this.intervalMs - performance.now());
    this.timer = setTimeout(() => this.flush(), wait);
  }

  async flush() {
    // A browser's timer may fire a little early by performance.now()'s clock: wait out the rest
    // rather than send inside the interval.
    const early = this.lastSentAt + this.intervalMs - performance.now();
    if (early > 0) {
      this.timer = setTimeout(() => this.flush(), early);
      return;
    }
    this.timer = null;
    const changes = this.pending;
    this.pending = null;
    if (!changes) return;
    this.lastSentAt = performance.now();
    const reply = await this.socket.request({ type: this.type, changes });
    this.onReply(reply, leafPaths(changes));
  }
}
