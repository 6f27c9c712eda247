// MikkTSpace tangents (the npm `mikktspace` package: a WebAssembly build of
// a port of Mikkelsen's reference C code) for an unindexed triangle list, for
// tests/mesh/mikktspace_test.cpp.
//
//   node mikktspace_tangents.cjs NODE_MODULES_DIR IN OUT
//
// IN:  uint32 corner count c (3 per triangle), then float32 positions[3c],
//      normals[3c], uvs[2c] (little-endian; texture v up, as Mucosa's).
// OUT: float32 tangents[4c] (xyz, w = handedness with B = w cross(N, T)).
'use strict';
const fs = require('fs');
const path = require('path');

const [modules, inFile, outFile] = process.argv.slice(2);
if (!outFile) {
    console.error('usage: node mikktspace_tangents.cjs NODE_MODULES_DIR IN OUT');
    process.exit(2);
}
const { generateTangents } = require(path.join(modules, 'mikktspace'));

const buf = fs.readFileSync(inFile);
const c = buf.readUInt32LE(0);
if (buf.length !== 4 + 4 * (3 * c + 3 * c + 2 * c)) {
    console.error(`error: size of ${inFile} does not match its ${c} corners`);
    process.exit(1);
}
const floats = new Float32Array(buf.buffer.slice(buf.byteOffset + 4, buf.byteOffset + buf.length));
const positions = floats.subarray(0, 3 * c);
const normals = floats.subarray(3 * c, 6 * c);
const uvs = floats.subarray(6 * c, 8 * c);
const tangents = generateTangents(positions, normals, uvs);
if (tangents.length !== 4 * c) {
    console.error(`error: mikktspace returned ${tangents.length} values for ${c} corners`);
    process.exit(1);
}
fs.writeFileSync(outFile, Buffer.from(tangents.buffer, tangents.byteOffset, tangents.byteLength));
