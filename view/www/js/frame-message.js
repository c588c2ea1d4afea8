// A binary WebSocket frame: u32 little-endian n, n bytes of JSON (the frame's description),
// the render's JPEG (render_bytes), the B-scan's JPEG (bscan_bytes), then the B-scan pair through
// the instrument's tip (tip_bscans_bytes; 0 without an instrument).
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
