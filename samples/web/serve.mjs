#!/usr/bin/env node
// Tiny static server for the viewer (Node's http module only). Serves samples/web/ (the page,
// its modules and node_modules/), format/js/ under /format/js/ (the reader and the three.js
// plugin the viewer is built on) and the given files under /files/, and prints the URL.
//
//   npm ci --prefix samples/web
//   node samples/web/serve.mjs --avatar out/demo/avatar.glb --motion out/demo/motion_wave.npz
//        [--camera cam.json] [--port 8080] [--host 127.0.0.1]
//
// Extra viewer parameters (frame=, gaussians=0, bg=, size=, skin=gltf) can be appended to
// the printed URL. `startServer` is also used by the browser test.
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const formatJs = path.resolve(here, '..', '..', 'format', 'js');
const TYPES = {
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.mjs': 'text/javascript; charset=utf-8',
  '.json': 'application/json', '.wasm': 'application/wasm', '.glb': 'model/gltf-binary', '.npz': 'application/octet-stream',
  '.png': 'image/png', '.css': 'text/css',
};

// files: { name: absolute path } served as /files/<name>. Returns { server, url }.
export function startServer({ files = {}, port = 8080, host = '127.0.0.1', quiet = false } = {}) {
  const server = http.createServer((req, res) => {
    const u = new URL(req.url, 'http://x');
    let p = decodeURIComponent(u.pathname);
    let file;
    if (p.startsWith('/files/')) {
      file = files[p.slice(7)];
    } else if (p.startsWith('/format/js/')) {  // the engine-free reader and the three.js plugin
      file = path.join(formatJs, path.normalize(p.slice(11)).replace(/^(\.\.[/\\])+/, ''));
      if (!file.startsWith(formatJs + path.sep)) file = undefined;
    } else {
      if (p === '/') p = '/index.html';
      file = path.join(here, path.normalize(p).replace(/^(\.\.[/\\])+/, ''));
      if (!file.startsWith(here + path.sep)) file = undefined;
    }
    if (!file || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      res.writeHead(404, { 'content-type': 'text/plain' });
      res.end(`not found: ${p}\n`);
      if (!quiet) console.error(`404 ${p}`);
      return;
    }
    res.writeHead(200, { 'content-type': TYPES[path.extname(file)] || 'application/octet-stream', 'cache-control': 'no-store' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve, reject) => {
    server.on('error', reject);
    server.listen(port, host, () => {
      const a = server.address();
      resolve({ server, base: `http://${host}:${a.port}/` });
    });
  });
}

// URL of the viewer page for the served files and extra parameters.
export function viewerUrl(base, files, extra = {}) {
  const q = new URLSearchParams();
  for (const k of ['avatar', 'motion', 'camera']) if (files[k]) q.set(k, `files/${k}${path.extname(files[k])}`);
  for (const [k, v] of Object.entries(extra)) q.set(k, String(v));
  return `${base}?${q.toString()}`;
}

// Served names: avatar.glb, motion.npz, camera.json.
export function servedFiles(opts) {
  const files = {}, named = {};
  for (const k of ['avatar', 'motion', 'camera']) {
    if (!opts[k]) continue;
    const abs = path.resolve(opts[k]);
    if (!fs.existsSync(abs)) throw new Error(`--${k}: ${opts[k]} does not exist`);
    files[`${k}${path.extname(abs)}`] = abs;
    named[k] = abs;
  }
  return { files, named };
}

const isMain = process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url);
if (isMain) {
  const opts = { port: 8080, host: '127.0.0.1' };
  const args = process.argv.slice(2);
  for (let i = 0; i < args.length; i++) {
    const k = args[i];
    if (k === '-h' || k === '--help') {
      console.log('usage: node samples/web/serve.mjs --avatar AVATAR.glb [--motion MOTION.npz] [--camera cam.json] [--port N] [--host H]');
      process.exit(0);
    }
    if (!k.startsWith('--') || i + 1 >= args.length) { console.error(`serve.mjs: bad argument '${k}' (--help)`); process.exit(2); }
    opts[k.slice(2)] = args[++i];
  }
  if (!opts.avatar) { console.error('serve.mjs: --avatar is required (--help)'); process.exit(2); }
  if (!fs.existsSync(path.join(here, 'node_modules', 'three'))) {
    console.error('serve.mjs: node_modules missing: run  npm ci --prefix samples/web'); process.exit(1);
  }
  try {
    const { files, named } = servedFiles(opts);
    const { base } = await startServer({ files, port: Number(opts.port), host: opts.host });
    console.log(`haha viewer: ${viewerUrl(base, named)}`);
    console.log('(Ctrl-C to stop)');
  } catch (e) {
    console.error(`serve.mjs: ${e.message}`);
    process.exit(1);
  }
}
