// Encodes a raw 64x64 RGBA raster as KTX2 (UASTC and ETC1S) and, with the same settings, as
// .basis, transcoded to RGBA32 by Basis Universal's own transcoder as the reference (see INDEX.md).
import { NodeBasisEncoder } from "ktx2-encoder";
import { readFileSync, writeFileSync } from "node:fs";
const [raw, w, h, outDir] = process.argv.slice(2);
const data = new Uint8Array(readFileSync(raw));
const imageDecoder = async () => ({ data, width: Number(w), height: Number(h) });
const enc = new NodeBasisEncoder();
const module = await enc.init();
for (const mode of ["uastc", "etc1s"]) {
  const opts = { isUASTC: mode === "uastc", generateMipmap: false, imageDecoder };
  const ktx2 = await enc.encode(new Uint8Array(8), { ...opts, isKTX2File: true });
  const basis = await enc.encode(new Uint8Array(8), { ...opts, isKTX2File: false });
  writeFileSync(`${outDir}/${mode}.ktx2`, ktx2);
  const f = new module.BasisFile(basis);
  if (!f.startTranscoding()) throw new Error("startTranscoding");
  const size = f.getImageTranscodedSizeInBytes(0, 0, 13);
  const dst = new Uint8Array(size);
  if (!f.transcodeImage(dst, 0, 0, 13, 0, 0)) throw new Error("transcodeImage");
  writeFileSync(`${outDir}/${mode}.reference.rgba`, dst);
  console.log(mode, ktx2.length, basis.length, size);
  f.close(); f.delete();
}
