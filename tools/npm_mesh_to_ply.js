#!/usr/bin/env node
// Converts an npm mesh module exporting {positions: [[x,y,z],...], cells: [[i,j,k,...],...]}
// (e.g. the `bunny` and `teapot` packages) to a binary little-endian PLY file.
//   node tools/npm_mesh_to_ply.js <module.js> <out.ply> [comment]
'use strict';
const fs = require('fs');
const path = require('path');

function fail(message) {
  process.stderr.write(`npm_mesh_to_ply: ${message}\n`);
  process.exit(1);
}

const args = process.argv.slice(2);
if (args.length < 2 || args[0] === '--help' || args[0] === '-h') {
  process.stdout.write('usage: node tools/npm_mesh_to_ply.js <module.js> <out.ply> [comment]\n');
  process.exit(args.length < 2 && !(args[0] === '--help' || args[0] === '-h') ? 1 : 0);
}
const [input, output, comment] = args;

let mesh;
try {
  mesh = require(path.resolve(input));
} catch (e) {
  fail(`cannot load ${input}: ${e.message}`);
}
const positions = mesh && mesh.positions;
const cells = mesh && mesh.cells;
if (!Array.isArray(positions) || !Array.isArray(cells)) {
  fail(`${input} does not export {positions, cells} arrays`);
}
positions.forEach((p, i) => {
  if (!Array.isArray(p) || p.length !== 3 || !p.every(Number.isFinite)) {
    fail(`${input}: position ${i} is not three finite numbers`);
  }
});
cells.forEach((c, i) => {
  if (!Array.isArray(c) || c.length < 3 || c.length > 255 ||
      !c.every((v) => Number.isInteger(v) && v >= 0 && v < positions.length)) {
    fail(`${input}: cell ${i} is not a polygon of valid vertex indices`);
  }
});

const header = [
  'ply',
  'format binary_little_endian 1.0',
  `comment ${comment || 'converted from ' + path.basename(input)} by tools/npm_mesh_to_ply.js`,
  `element vertex ${positions.length}`,
  'property float x',
  'property float y',
  'property float z',
  `element face ${cells.length}`,
  'property list uchar int vertex_indices',
  'end_header',
  '',
].join('\n');

const faceBytes = cells.reduce((n, c) => n + 1 + 4 * c.length, 0);
const body = Buffer.alloc(positions.length * 12 + faceBytes);
let o = 0;
for (const p of positions) {
  for (const v of p) {
    body.writeFloatLE(v, o);
    o += 4;
  }
}
for (const c of cells) {
  body.writeUInt8(c.length, o);
  o += 1;
  for (const v of c) {
    body.writeInt32LE(v, o);
    o += 4;
  }
}

const tmp = `${output}.tmp${process.pid}`;
try {
  fs.writeFileSync(tmp, Buffer.concat([Buffer.from(header, 'ascii'), body]));
  fs.renameSync(tmp, output);
} catch (e) {
  fail(`cannot write ${output}: ${e.message}`);
}
process.stdout.write(`${output}: ${positions.length} vertices, ${cells.length} faces\n`);
