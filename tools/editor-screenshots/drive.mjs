// Drives `tessera lsp` as an editor would and records its answers, plus TextMate tokens of the
// text, for the editor screenshot page.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
const require = createRequire(import.meta.url);
const vsctm = require('vscode-textmate');
const oniguruma = require('vscode-oniguruma');

const [bin, proj, scene, grammarPath, out] = process.argv.slice(2);
const file = path.resolve(proj, scene);
let text = fs.readFileSync(file, 'utf8');
// The broken edit an artist might make: a misspelt property.
text = text.replace('  grid = hex\n', '  gird = hex\n');
// And, in a second version, a property being typed in the layer above.
const typed = text.replace('  cell = 0.3\n', '  cell = 0.3\n  co\n');
const uri = 'file://' + file;

const child = spawn(bin, ['lsp'], { cwd: proj, stdio: ['pipe', 'pipe', 'inherit'] });
let buf = Buffer.alloc(0);
const waiting = new Map();
const notes = [];
child.stdout.on('data', (d) => {
  buf = Buffer.concat([buf, d]);
  for (;;) {
    const head = buf.indexOf('\r\n\r\n');
    if (head < 0) return;
    const len = +/Content-Length: (\d+)/.exec(buf.slice(0, head).toString())[1];
    if (buf.length < head + 4 + len) return;
    const msg = JSON.parse(buf.slice(head + 4, head + 4 + len).toString());
    buf = buf.slice(head + 4 + len);
    if (msg.id !== undefined && waiting.has(msg.id)) { waiting.get(msg.id)(msg); waiting.delete(msg.id); }
    else notes.push(msg);
  }
});
const send = (m) => { const s = JSON.stringify(m); child.stdin.write(`Content-Length: ${Buffer.byteLength(s)}\r\n\r\n${s}`); };
let id = 0;
const request = (method, params) => new Promise((ok) => { const i = ++id; waiting.set(i, ok); send({ jsonrpc: '2.0', id: i, method, params }); });
const notify = (method, params) => send({ jsonrpc: '2.0', method, params });
const lines = text.split('\n');
const at = (needle, dx = 0) => { const line = lines.findIndex((l) => l.includes(needle)); return { line, character: lines[line].indexOf(needle) + dx }; };

await request('initialize', { processId: null, rootUri: 'file://' + path.resolve(proj), capabilities: {} });
notify('initialized', {});
notify('textDocument/didOpen', { textDocument: { uri, languageId: 'tessera', version: 1, text } });
let diags;
for (let t = 0; t < 100 && !diags; t++) {
  await new Promise((r) => setTimeout(r, 50));
  diags = notes.find((n) => n.method === 'textDocument/publishDiagnostics' && n.params.uri === uri)?.params.diagnostics;
}
const hoverAt = at('layer hexes', 2);
const hover = (await request('textDocument/hover', { textDocument: { uri }, position: hoverAt })).result;
// Completion on the empty line typed at the end of `layer triangles`.
const lines2 = typed.split('\n');
const completeLine = lines2.findIndex((l) => l === '  co');
notify('textDocument/didChange', { textDocument: { uri, version: 2 }, contentChanges: [{ text: typed }] });
const completion = (await request('textDocument/completion', { textDocument: { uri }, position: { line: completeLine, character: 4 } })).result;
await request('shutdown', null);
notify('exit', null);

const wasm = fs.readFileSync(require.resolve('vscode-oniguruma/release/onig.wasm')).buffer;
await oniguruma.loadWASM(wasm);
const registry = new vsctm.Registry({
  onigLib: Promise.resolve({ createOnigScanner: (p) => new oniguruma.OnigScanner(p), createOnigString: (s) => new oniguruma.OnigString(s) }),
  loadGrammar: async () => vsctm.parseRawGrammar(fs.readFileSync(grammarPath, 'utf8'), grammarPath),
});
const grammar = await registry.loadGrammar('source.tessera');
const tokenise = (lines) => { let state = vsctm.INITIAL; return lines.map((l) => { const r = grammar.tokenizeLine(l, state); state = r.ruleStack; return r.tokens.map((t) => ({ startIndex: t.startIndex, scopes: t.scopes[t.scopes.length - 1] })); }); };
fs.writeFileSync(out, JSON.stringify({ text, tokens: tokenise(lines), typed, typedTokens: tokenise(lines2), diags, hover, hoverAt, completion, completeAt: { line: completeLine, character: 4 } }, null, 1));
console.log('diagnostics', JSON.stringify(diags).slice(0, 400));
console.log('hover', JSON.stringify(hover).slice(0, 200));
console.log('completion', (completion.items ?? completion).length, 'items');
