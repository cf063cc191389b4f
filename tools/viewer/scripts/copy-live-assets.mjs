// Copies what the live page loads at run time into public/live/ (Vite serves public/ in dev and
// copies it into dist/): the model manifest and the characters (tools/viewer/live/), the models it
// lists (../../models/), and the characters' MJCF (../../assets/). Nothing is downloaded.
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
let bytes = 0;
for (const m of manifest.models) {
  fs.mkdirSync(path.dirname(path.join(out, m.file)), { recursive: true });
  copy(path.join(repo, m.file), path.join(out, m.file));
  bytes += fs.statSync(path.join(out, m.file)).size;
}
console.log(`copy-live-assets: ${manifest.models.length} models (${(bytes / 1e6).toFixed(1)} MB), ${characters.size} characters → ${path.relative(repo, out)}`);
