// The page's WebSocket to ioct-view: says hello with the token (when there is one), hands frames
// and state messages on, matches replies to requests by id, and reconnects with backoff when the
// connection drops (250 ms, doubling, at most 4 s).
import { parseFrameMessage, FramePictures } from './frame-message.js';

const kFirstRetryMs = 250;
const kLongestRetryMs = 4000;
const kReplyTimeoutMs = 5000;

export class LiveSocket {
  constructor({ token = '', onFrame = () => {}, onState = () => {}, onOpen = () => {},
                onClose = () => {}, onProblem = () => {}, onFootswitch = () => {},
                onOwnViewClosed = () => {} } = {}) {
    Object.assign(this,
      { token, onFrame, onState, onOpen, onClose, onProblem, onFootswitch, onOwnViewClosed });
    this.retryMs = kFirstRetryMs;
    this.nextId = 1;
    this.pending = new Map();
    this.ws = null;
  }

  get open() { return this.ws !== null && this.ws.readyState === WebSocket.OPEN; }

  connect() {
    const scheme = window.location.protocol === 'https:' ? 'wss:' : 'ws:';
    const ws = new WebSocket(`${scheme}//${window.location.host}/ws`);
    ws.binaryType = 'arraybuffer';
    this.ws = ws;
    this.pictures = new FramePictures();  // a new connection sends its pictures first
    ws.onopen = () => {
      this.retryMs = kFirstRetryMs;
      if (this.token) ws.send(JSON.stringify({ type: 'hello', token: this.token }));
      this.onOpen();
    };
    ws.onmessage = (event) => this.receive(event.data);
    ws.onclose = (event) => {
      if (this.ws !== ws) return;
      this.ws = null;
      for (const { reject } of this.pending.values()) reject(new Error('connection closed'));
      this.pending.clear();
      this.onClose(event.reason || `connection closed (${event.code})`);
      setTimeout(() => this.connect(), this.retryMs);
      this.retryMs = Math.min(this.retryMs * 2, kLongestRetryMs);
    };
  }

  receive(data) {
    try {
      if (typeof data !== 'string') {
        let frame;
        try {
          frame = this.pictures.complete(parseFrameMessage(data));
        } catch (error) {
          this.pictures.forget();  // the frames after it must not repeat what it may have brought
          throw error;
        }
        this.onFrame(frame);
        return;
      }
      const message = JSON.parse(data);
      if (message.type === 'state') {
        this.onState(message);
      } else if (message.type === 'footswitch') {
        this.onFootswitch(message.action);
      } else if (message.type === 'own_view_closed') {
        this.onOwnViewClosed(String(message.reason || ''));
      } else if (message.type === 'reply' && this.pending.has(message.id)) {
        const { resolve, timer } = this.pending.get(message.id);
        clearTimeout(timer);
        this.pending.delete(message.id);
        resolve(message);
      }
    } catch (error) {
      this.onProblem(`bad message from the server: ${error.message}`);
    }
  }

  // Sends without waiting for a reply; false when not connected.
  send(message) {
    if (!this.open) return false;
    this.ws.send(JSON.stringify(message));
    return true;
  }

  // Sends with an id and resolves with the server's reply ({ok, error, key, ...}).
  request(message) {
    if (!this.open) return Promise.resolve({ ok: false, error: 'not connected to the appliance' });
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      const timer = setTimeout(() => {
        this.pending.delete(id);
        resolve({ ok: false, error: 'no reply from the appliance in 5 s' });
      }, kReplyTimeoutMs);
      this.pending.set(id, { resolve, reject, timer });
      this.ws.send(JSON.stringify({ ...message, id }));
    }).catch((error) => ({ ok: false, error: error.message }));
  }
}
