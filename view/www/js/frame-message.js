// A binary WebSocket frame: u32 little-endian n, n bytes of JSON (the frame's description),
// the render's JPEG (render_bytes), the B-scan's JPEG (bscan_bytes), then the B-scan pair through
// the instrument's tip (tip_bscans_bytes; 0 without an instrument). A frame marked
// pictures_repeated carries neither: its B-scan and pair are the last ones this connection
// received (FramePictures fills them in).
export function parseFrameMessage(buffer) {
  if (buffer.byteLength < 4) throw new Error(`frame message of ${buffer.byteLength} bytes`);
  const jsonBytes = new DataView(buffer).getUint32(0, true);
  if (4 + jsonBytes > buffer.byteLength) throw new Error('frame message: JSON runs past the end');
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, jsonBytes)));
  const renderStart = 4 + jsonBytes;
  const renderBytes = meta.render_bytes >>> 0;
  const bscanBytes = meta.bscan_bytes >>> 0;
  const tipBytes = meta.tip_bscans_bytes >>> 0;
  if (renderStart + renderBytes + bscanBytes + tipBytes > buffer.byteLength) {
    throw new Error('frame message: images run past the end');
  }
  return {
    meta,
    render: new Uint8Array(buffer, renderStart, renderBytes),
    bscan: new Uint8Array(buffer, renderStart + renderBytes, bscanBytes),
    tipBscans: new Uint8Array(buffer, renderStart + renderBytes + bscanBytes, tipBytes),
  };
}

// Makes frames whole on one connection: a frame with pictures is remembered, one marked
// pictures_repeated gets that frame's B-scan and pair (and their sizes in its description), but
// only if they are the pictures it names (`pictures`): never an older B-scan shown as current.
export class FramePictures {
  constructor() { this.last = null; }

  // After a frame that could not be read: whatever it brought is unknown.
  forget() { this.last = null; }

  complete(frame) {
    const { meta } = frame;
    if (!meta.pictures_repeated) {
      this.last = { number: meta.pictures, bscan: frame.bscan, tipBscans: frame.tipBscans,
                    bscanBytes: meta.bscan_bytes, tipBytes: meta.tip_bscans_bytes };
      return frame;
    }
    if (!this.last || this.last.number !== meta.pictures) {
      throw new Error(`frame ${meta.frame} repeats pictures ${meta.pictures}, never received`);
    }
    meta.bscan_bytes = this.last.bscanBytes;
    meta.tip_bscans_bytes = this.last.tipBytes;
    return { ...frame, bscan: this.last.bscan, tipBscans: this.last.tipBscans };
  }
}
