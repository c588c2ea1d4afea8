// Draws frames onto the render and B-scan canvases as they come, newest first: while one frame
// is being decoded, a newer one replaces any other waiting (a slow page drops frames, it never
// falls behind). The render is new in every frame; the B-scan and the tip's pair are decoded
// only when their bytes change (repeated-picture.js). After drawing it calls onDrawn(meta), which
// tells the server (published → drawn).
import { drawTipMarker, drawTipBscanMarkers, drawRenderTipMarker } from './instrument-readout.js';
import { RepeatedPicture, decodeJpeg } from './repeated-picture.js';

export class FramePainter {
  constructor({ renderCanvas, bscanCanvas, tipCanvas = null, onDrawn = () => {}, onProblem = () => {} }) {
    Object.assign(this, { renderCanvas, bscanCanvas, tipCanvas, onDrawn, onProblem });
    this.busy = false;
    this.waiting = null;
    this.tipMarked = false;  // the last B-scan drawn has the instrument's tip marked on it
    this.tipOnRender = false;  // ... and the last render
    this.bscanPicture = new RepeatedPicture();
    this.tipPicture = new RepeatedPicture();
  }

  paint(frame) {
    this.waiting = frame;
    if (!this.busy) this.drain();
  }

  async drain() {
    this.busy = true;
    while (this.waiting) {
      const frame = this.waiting;
      this.waiting = null;
      try {
        await this.draw(frame);
        this.onDrawn(frame.meta);
      } catch (error) {
        this.onProblem(`frame ${frame.meta.frame} could not be drawn: ${error.message}`);
      }
    }
    this.busy = false;
  }

  async draw({ meta, render, bscan, tipBscans }) {
    const tipShown = Boolean(this.tipCanvas && tipBscans && tipBscans.byteLength > 0);
    const settled = await Promise.allSettled([
      decodeJpeg(render),
      bscan.byteLength > 0 ? this.bscanPicture.picture(bscan) : null,
      tipShown ? this.tipPicture.picture(tipBscans) : null,
    ]);
    const failed = settled.find((s) => s.status === 'rejected');
    if (failed) {
      if (settled[0].status === 'fulfilled') settled[0].value.close();  // the others are kept
      throw failed.reason;
    }
    const images = settled.map((s) => s.value);
    drawBitmap(this.renderCanvas, images[0]);
    this.tipOnRender = drawRenderTipMarker(this.renderCanvas, meta);
    if (images[1]) {
      drawBitmap(this.bscanCanvas, images[1]);
      this.tipMarked = drawTipMarker(this.bscanCanvas, meta);
    }
    if (this.tipCanvas) {
      this.tipCanvas.hidden = !tipShown;
      if (images[2]) {
        drawBitmap(this.tipCanvas, images[2]);
        drawTipBscanMarkers(this.tipCanvas, meta);
      }
    }
    images[0].close();  // the others stay with their RepeatedPicture for the next frames
  }
}

function drawBitmap(canvas, bitmap) {
  if (canvas.width !== bitmap.width) canvas.width = bitmap.width;
  if (canvas.height !== bitmap.height) canvas.height = bitmap.height;
  canvas.getContext('2d').drawImage(bitmap, 0, 0);
}
