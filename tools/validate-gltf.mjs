// Validates .glb files with the Khronos glTF validator (npm package `gltf-validator`, installed
// outside the repository): `node tools/validate-gltf.mjs a.glb [b.glb ...]`.
//
// The package is looked up in the node_modules directory named by TESSERA_GLTF_VALIDATOR, else
// in tools/node_modules. Prints each file's counts and its messages (errors and warnings; infos
// and hints too, marked as such) and exits 1 if any file has an error, 2 on bad usage or a
// missing validator. Warnings do not fail.
import { createRequire } from 'node:module';
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const modules = process.env.TESSERA_GLTF_VALIDATOR || path.join(here, 'node_modules');
const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: validate-gltf.mjs FILE.glb...');
  process.exit(2);
}
let validator;
try {
  validator = createRequire(path.join(modules, 'resolve-from-here.js'))('gltf-validator');
} catch (e) {
  console.error(`gltf-validator not found under ${modules}: ${e.message}`);
  process.exit(2);
}

const severities = ['error', 'warning', 'info', 'hint'];
let failed = false;
for (const file of files) {
  const bytes = new Uint8Array(readFileSync(file));
  const report = await validator.validateBytes(bytes, { uri: path.basename(file), maxIssues: 100 });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ${numHints} hints ` +
    `(validator ${report.validatorVersion})`);
  for (const m of messages) {
    console.log(`  ${severities[m.severity] ?? m.severity}: ${m.code} ${m.pointer ?? ''} ${m.message}`);
  }
  if (numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
