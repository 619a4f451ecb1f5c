#!/usr/bin/env node
// Tokenises .knit files with the extension's grammar (vscode-textmate, the engine VS Code
// uses) and fails if any token gets an `invalid` scope, or if a file ends inside a string,
// grid, comment or bracket that the grammar never closed. Every file it checks compiles, so
// either would be a grammar bug.
//
//   node tests/no-invalid.js                  the repository's examples/ and stdlib/std/
//   node tests/no-invalid.js FILE...          those files
//   node tests/no-invalid.js --dump FILE...   print every token and its scopes instead
"use strict";

const fs = require("fs");
const path = require("path");
const vsctm = require("vscode-textmate");
const oniguruma = require("vscode-oniguruma");

const here = __dirname;
const extension = path.resolve(here, "..");
const repo = path.resolve(extension, "..", "..");
const grammarPath = path.join(extension, "syntaxes", "knit.tmLanguage.json");

function knitFiles(dir) {
  const out = [];
  for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
    const full = path.join(dir, entry.name);
    if (entry.isDirectory()) out.push(...knitFiles(full));
    else if (entry.name.endsWith(".knit")) out.push(full);
  }
  return out.sort();
}

async function loadGrammar() {
  const wasm = fs.readFileSync(require.resolve("vscode-oniguruma/release/onig.wasm"));
  await oniguruma.loadWASM(wasm.buffer.slice(wasm.byteOffset, wasm.byteOffset + wasm.byteLength));
  const registry = new vsctm.Registry({
    onigLib: Promise.resolve({
      createOnigScanner: (sources) => new oniguruma.OnigScanner(sources),
      createOnigString: (s) => new oniguruma.OnigString(s),
    }),
    loadGrammar: async (scopeName) =>
      scopeName === "source.knit"
        ? vsctm.parseRawGrammar(fs.readFileSync(grammarPath, "utf8"), grammarPath)
        : null,
  });
  return registry.loadGrammar("source.knit");
}

function tokenise(grammar, text) {
  const lines = text.split(/\r?\n/);
  const out = [];
  let stack = vsctm.INITIAL;
  for (let i = 0; i < lines.length; i++) {
    const r = grammar.tokenizeLine(lines[i], stack);
    for (const t of r.tokens) {
      out.push({ line: i + 1, col: t.startIndex + 1, text: lines[i].slice(t.startIndex, t.endIndex), scopes: t.scopes });
    }
    stack = r.ruleStack;
  }
  return { tokens: out, closed: stack.depth <= 1, depth: stack.depth };
}

async function main() {
  const args = process.argv.slice(2);
  const dump = args[0] === "--dump";
  if (dump) args.shift();
  const files = args.length
    ? args.map((f) => path.resolve(f))
    : [...knitFiles(path.join(repo, "examples")), ...knitFiles(path.join(repo, "stdlib", "std"))];
  if (!files.length) {
    console.error("no-invalid: no .knit files found");
    process.exit(2);
  }
  const grammar = await loadGrammar();
  let problems = 0;
  for (const file of files) {
    const rel = path.relative(process.cwd(), file);
    const { tokens, closed } = tokenise(grammar, fs.readFileSync(file, "utf8"));
    if (dump) {
      for (const t of tokens) console.log(`${rel}:${t.line}:${t.col}\t${JSON.stringify(t.text)}\t${t.scopes.slice(1).join(" ")}`);
      continue;
    }
    for (const t of tokens) {
      if (t.scopes.some((s) => s.split(".").includes("invalid"))) {
        console.log(`${rel}:${t.line}:${t.col}: ${JSON.stringify(t.text)} has ${t.scopes.slice(1).join(" ")}`);
        problems++;
      }
    }
    if (!closed) {
      console.log(`${rel}: ends inside an unclosed grammar rule (a string, grid, comment or bracket)`);
      problems++;
    }
  }
  if (!dump) {
    console.log(`no-invalid: ${files.length} files, ${problems} problem${problems === 1 ? "" : "s"}`);
  }
  process.exit(problems ? 1 : 0);
}

main().catch((e) => {
  console.error(e && e.stack ? e.stack : e);
  process.exit(2);
});
