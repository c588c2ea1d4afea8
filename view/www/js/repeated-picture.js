// A picture that most frames carry again unchanged (the B-scan beside the render, the tip's B-scan
// pair: ioct-gpu encodes them anew only when a pass changed them, and every frame carries the
// latest): decoded once, and the same bitmap handed out while the bytes stay the same. The bitmap
// belongs to this object; it closes the one it replaces.
export function decodeJpeg(bytes) {
  return createImageBitmap(new Blob([bytes], { type: 'image/jpeg' }));
}

export class RepeatedPicture {
  constructor(decode = decodeJpeg) {
    this.decode = decode;
    this.bytes = null;
    this.bitmap = null;
  }

  // The bitmap of `bytes` (a Uint8Array), decoding only when they differ from the last ones.
  async picture(bytes) {
    if (this.bitmap && sameBytes(bytes, this.bytes)) return this.bitmap;
    const bitmap = await this.decode(bytes);
    this.bitmap?.close();
    this.bitmap = bitmap;
    this.bytes = bytes;
    return bitmap;
  }
}

function sameBytes(a, b) {
  if (a === b) return true;  // a repeated frame hands on the very same bytes
  if (a.byteLength !== b.byteLength) return false;
  for (let i = 0; i < a.length; i += 1) {
    if (a[i] !== b[i]) return false;
  }
  return true;
}
