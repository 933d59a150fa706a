#!/usr/bin/env node
// Serves the built viewer (dist/) and the recordings given on the command line on localhost only:
//   node tools/viewer/serve.mjs [--port P] FILE...
// The page asks recordings/list.json for what to play; recordings/<i> streams file i. Nothing is
// fetched from the network: the page is the bundle built from the npm packages in package-lock.json.
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const dist = path.join(here, 'dist');
const TYPES = { '.html': 'text/html; charset=utf-8', '.js': 'text/javascript', '.css': 'text/css', '.map': 'application/json',
  '.json': 'application/json' };

/// Starts the server; resolves to {server, url}. Tries `port` and the next 20 if it is taken.
export function startServer(files, port = 8765, host = '127.0.0.1') {
  for (const f of files) if (!fs.existsSync(f) || !fs.statSync(f).isFile()) throw new Error(`no such recording: ${f}`);
  if (!fs.existsSync(path.join(dist, 'index.html'))) throw new Error(`the viewer is not built (${dist}); run scripts/dev view, or npm run build in ${here}`);
  const list = files.map((f, i) => ({ name: path.basename(f), url: `recordings/${i}`, size: fs.statSync(f).size }));
  const handler = (req, res) => {
    const url = new URL(req.url, 'http://localhost');
    const send = (code, type, body) => { res.writeHead(code, { 'Content-Type': type, 'Cache-Control': 'no-store' }); res.end(body); };
    if (url.pathname === '/recordings/list.json') return send(200, TYPES['.json'], JSON.stringify(list));
    const m = url.pathname.match(/^\/recordings\/(\d+)$/);
    if (m) {
      const i = Number(m[1]);
      if (i >= files.length) return send(404, 'text/plain', 'no such recording');
      res.writeHead(200, { 'Content-Type': 'application/octet-stream', 'Content-Length': fs.statSync(files[i]).size, 'Cache-Control': 'no-store' });
      return fs.createReadStream(files[i]).pipe(res);
    }
    const rel = url.pathname === '/' ? 'index.html' : url.pathname.slice(1);
    const file = path.join(dist, path.normalize(rel));
    if (!file.startsWith(dist + path.sep) || !fs.existsSync(file) || !fs.statSync(file).isFile()) return send(404, 'text/plain', 'not found');
    send(200, TYPES[path.extname(file)] || 'application/octet-stream', fs.readFileSync(file));
  };
  return new Promise((resolve, reject) => {
    const tryPort = (p, left) => {
      const server = http.createServer(handler);
      server.once('error', (e) => (e.code === 'EADDRINUSE' && left > 0 ? tryPort(p + 1, left - 1) : reject(e)));
      server.listen(p, host, () => resolve({ server, url: `http://${host}:${server.address().port}/` }));
    };
    tryPort(port, port === 0 ? 0 : 20);
  });
}

if (process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  const args = process.argv.slice(2);
  let port = 8765;
  const files = [];
  for (let i = 0; i < args.length; ++i) {
    if (args[i] === '--port') port = Number(args[++i]);
    else if (args[i].startsWith('-')) { console.error(`serve: unknown option ${args[i]}`); process.exit(2); }
    else files.push(args[i]);
  }
  if (!Number.isInteger(port) || port < 0 || port > 65535) { console.error('serve: --port needs a number 0-65535'); process.exit(2); }
  try {
    const { url } = await startServer(files, port);
    console.log(`Sinew viewer: ${url}  (${files.length} recording${files.length === 1 ? '' : 's'}; open it in a browser, Ctrl-C stops)`);
  } catch (e) {
    console.error(`serve: ${e.message}`);
    process.exit(1);
  }
}
