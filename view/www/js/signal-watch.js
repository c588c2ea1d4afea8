// What the picture may claim to be. It is live only while the server says `live`, messages keep
// coming (a state or frame within the last second), the WebSocket is open and the picture drawn
// is itself recent (its newest scan no older than the server's stale bound); anything else is
// STALE (the server says so, or the picture lags the scan: a renderer slower than the scanner, a
// render stream that stopped) or NO SIGNAL (the server says so, is silent, or is unreachable).
export const kSilenceMs = 1000;

export class SignalWatch {
  constructor(now = () => performance.now()) {
    this.now = now;
    this.connected = false;
    this.lastMessageAt = -Infinity;
    this.serverSignal = 'no_signal';
    this.serverAgeMs = null;  // the newest group's age when the state was sent
    this.serverReason = '';
    this.stateAt = -Infinity;
    this.lastLiveAt = null;   // when the picture was last known live (for the age while lost)
    this.staleAfterMs = null; // the server's bound on the newest scan's age
    this.pictureAgeMs = null; // the drawn picture's newest scan's age when its frame was sent
    this.pictureAt = null;    // when that picture's message arrived
  }

  connection(open) {
    this.connected = open;
    if (!open) this.serverSignal = 'no_signal';
  }

  state(message) {
    this.lastMessageAt = this.stateAt = this.now();
    this.serverSignal = message.signal || 'no_signal';
    this.serverAgeMs = Number.isFinite(message.age_ms) ? message.age_ms : null;
    this.serverReason = typeof message.reason === 'string' ? message.reason : '';
    if (Number.isFinite(message.stale_after_ms) && message.stale_after_ms > 0) {
      this.staleAfterMs = message.stale_after_ms;
    }
    if (this.serverSignal === 'live') this.lastLiveAt = this.lastMessageAt;
  }

  frame() { this.lastMessageAt = this.now(); }

  // A picture was drawn: `ageMs` is its frame's age_ms (its newest scan published → frame sent),
  // `receivedAt` when its message arrived (the decoding's time counts towards its age).
  pictureDrawn(ageMs, receivedAt = this.now()) {
    this.pictureAgeMs = Number.isFinite(ageMs) ? ageMs : null;
    this.pictureAt = Number.isFinite(receivedAt) ? receivedAt : this.now();
  }

  // The drawn picture's newest scan's age now; null before the first picture with an age.
  pictureAge(now = this.now()) {
    return this.pictureAgeMs === null ? null : this.pictureAgeMs + (now - this.pictureAt);
  }

  // {signal: 'live'|'stale'|'no_signal', ageMs: number|null, reason: string}
  current() {
    const now = this.now();
    const sinceLive = this.lastLiveAt === null ? null : now - this.lastLiveAt;
    const serverAge = this.serverAgeMs === null ? sinceLive : this.serverAgeMs + (now - this.stateAt);
    if (!this.connected) {
      return { signal: 'no_signal', ageMs: sinceLive, reason: 'no connection to the appliance' };
    }
    if (now - this.lastMessageAt > kSilenceMs) {
      return { signal: 'no_signal', ageMs: sinceLive, reason: 'the appliance is silent' };
    }
    if (this.serverSignal === 'live') {
      const pictureAge = this.pictureAge(now);
      if (pictureAge !== null && this.staleAfterMs !== null && pictureAge > this.staleAfterMs) {
        return { signal: 'stale', ageMs: pictureAge,
          reason: 'the picture lags the scan (the renderer is behind)' };
      }
      return { signal: 'live', ageMs: serverAge, reason: '' };
    }
    if (this.serverSignal === 'stale') {
      return { signal: 'stale', ageMs: serverAge, reason: this.serverReason || 'no new scan data' };
    }
    return { signal: 'no_signal', ageMs: serverAge,
      reason: this.serverReason || 'the scanner or the pipeline is not running' };
  }
}

// "3.2 s", "1 min 05 s", "" for unknown.
export function formatAge(ms) {
  if (ms === null || !Number.isFinite(ms)) return '';
  const s = ms / 1000;
  if (s < 60) return `${s.toFixed(1)} s`;
  const whole = Math.floor(s);
  return `${Math.floor(whole / 60)} min ${String(whole % 60).padStart(2, '0')} s`;
}
