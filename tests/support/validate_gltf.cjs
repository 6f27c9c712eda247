// Validates glTF 2.0 files with the Khronos glTF-Validator (npm gltf-validator,
// installed under tools/node by scripts/install-deps) and prints one JSON
// line per file: {"file", "errors", "warnings", "infos", "hints", "unused",
// "messages": [{"code", "severity", "pointer", "message"}]} (severity 0 error,
// 1 warning, 2 info, 3 hint). Exit status: 0 when every file has no error, no
// warning and no UNUSED_* info; 1 otherwise; 2 when the validator cannot be
// loaded or a file cannot be read.
'use strict';
const fs = require('fs');
const path = require('path');

const moduleDir = path.join(__dirname, '..', '..', 'tools', 'node', 'node_modules', 'gltf-validator');
let validator;
try {
    validator = require(moduleDir);
} catch (e) {
    console.error(`gltf-validator is not installed in ${moduleDir} (run scripts/install-deps): ${e.message}`);
    process.exit(2);
}

async function validate(file) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, {
        uri: path.basename(file),
        maxIssues: 0,
        externalResourceFunction: (uri) =>
            new Promise((resolve, reject) => {
                const p = path.resolve(path.dirname(file), decodeURIComponent(uri));
                fs.readFile(p, (err, data) => (err ? reject(err.toString()) : resolve(new Uint8Array(data))));
            }),
    });
    const messages = report.issues.messages.map((m) => ({
        code: m.code, severity: m.severity, pointer: m.pointer || '', message: m.message,
    }));
    const unused = messages.filter((m) => m.code.startsWith('UNUSED_')).length;
    return {
        file, validatorVersion: report.validatorVersion, errors: report.issues.numErrors,
        warnings: report.issues.numWarnings, infos: report.issues.numInfos, hints: report.issues.numHints, unused,
        extensionsUsed: (report.info && report.info.extensionsUsed) || [], messages,
    };
}

(async () => {
    const files = process.argv.slice(2);
    if (files.length === 0) {
        console.error('usage: node validate_gltf.cjs FILE.glb|FILE.gltf ...');
        process.exit(2);
    }
    let clean = true;
    for (const f of files) {
        let r;
        try {
            r = await validate(f);
        } catch (e) {
            console.error(`${f}: ${e && e.message ? e.message : e}`);
            process.exit(2);
        }
        console.log(JSON.stringify(r));
        if (r.errors || r.warnings || r.unused) clean = false;
    }
    process.exit(clean ? 0 : 1);
})();
