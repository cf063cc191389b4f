// Copies what the live page loads at run time into public/live/ (Vite serves public/ in dev and
// copies it into dist/): the model manifest and the characters (tools/viewer/live/), the models it
// lists and the generator of its tracking models (../../models/, with tracking_<character>.json), and the characters' MJCF (../../assets/). Nothing is downloaded.
// Run by `npm run build` / `npm run dev` (prebuild / predev); fails naming a missing file.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const viewer = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const repo = path.resolve(viewer, '../..');
const out = path.join(viewer, 'public', 'live');
fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(path.join(out, 'models'), { recursive: true });

function copy(from, to) {
  if (!fs.existsSync(from)) {
    console.error(`copy-live-assets: missing ${path.relative(repo, from)}`);
    process.exit(1);
  }
  fs.copyFileSync(from, to);
}

const manifest = JSON.parse(fs.readFileSync(path.join(viewer, 'live', 'models.json'), 'utf8'));
copy(path.join(viewer, 'live', 'models.json'), path.join(out, 'models.json'));
const characters = new Set(manifest.models.map((m) => m.character));
for (const name of characters) {
  const file = path.join(viewer, 'live', `character_${name}.json`);
  copy(file, path.join(out, `character_${name}.json`));
  const ch = JSON.parse(fs.readFileSync(file, 'utf8'));
  copy(path.join(repo, 'assets', ch.mjcf), path.join(out, ch.mjcf));
}
// tracking models: their generator, and the character's tracking data (skeleton, histories)
for (const name of new Set(manifest.models.filter((m) => m.generator).map((m) => m.character)))
  copy(path.join(viewer, 'live', `tracking_${name}.json`), path.join(out, `tracking_${name}.json`));
let bytes = 0;
const files = new Set(manifest.models.flatMap((m) => (m.generator ? [m.file, m.generator] : [m.file])));
for (const file of files) {
  fs.mkdirSync(path.dirname(path.join(out, file)), { recursive: true });
  copy(path.join(repo, file), path.join(out, file));
  bytes += fs.statSync(path.join(out, file)).size;
}
console.log(`copy-live-assets: ${manifest.models.length} models (${(bytes / 1e6).toFixed(1)} MB), ${characters.size} characters → ${path.relative(repo, out)}`);
