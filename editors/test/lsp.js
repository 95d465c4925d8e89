// Speaks to `tslc lsp --stdio` the way the VS Code extension does: the
// server started as editors/vscode/extension.js starts it (vscode-languageclient
// appends `--stdio`), through vscode-jsonrpc, the JSON-RPC layer of
// vscode-languageclient, with the `importPaths` initialization option the
// extension sends. Walks the steps of the README's editor walk-through and
// fails on the first that does not hold.
//
// Usage: node editors/test/lsp.js TSLC REPO
"use strict";
const { spawn } = require("child_process");
const fs = require("fs");
const path = require("path");
const rpc = require("vscode-jsonrpc/node");

const [tslc, repo] = process.argv.slice(2);
const file = path.join(repo, "examples", "texture_tree.tsl");
const uri = "file://" + file;
const text = fs.readFileSync(file, "utf8");

function positionAfter(anchor, needle) {
  const from = text.indexOf(anchor);
  const k = text.indexOf(needle, from) + 1;
  const before = text.slice(0, k);
  const line = before.split("\n").length - 1;
  return { line, character: k - (before.lastIndexOf("\n") + 1) };
}

function check(what, ok, detail) {
  if (!ok) {
    console.error(`FAIL ${what}: ${JSON.stringify(detail)}`);
    process.exit(1);
  }
  console.log(`ok   ${what}`);
}

async function main() {
  const child = spawn(tslc, ["lsp", "--stdio"], { stdio: ["pipe", "pipe", "inherit"] });
  const conn = rpc.createMessageConnection(
    new rpc.StreamMessageReader(child.stdout),
    new rpc.StreamMessageWriter(child.stdin)
  );
  const published = [];
  let waiting = null;
  conn.onNotification("textDocument/publishDiagnostics", (p) => {
    published.push(p);
    if (waiting) waiting();
  });
  conn.listen();
  const diagnosticsOf = async (version) => {
    for (;;) {
      const found = published.find((p) => p.uri === uri && p.version === version);
      if (found) return found.diagnostics;
      await new Promise((resolve) => (waiting = resolve));
    }
  };

  const init = await conn.sendRequest("initialize", {
    processId: process.pid,
    rootUri: "file://" + repo,
    workspaceFolders: [{ uri: "file://" + repo, name: "tsl" }],
    capabilities: { textDocument: { completion: { completionItem: { snippetSupport: true } } } },
    initializationOptions: { importPaths: [] },
  });
  check("initialize", init.capabilities.completionProvider && init.capabilities.definitionProvider, init);
  conn.sendNotification("initialized", {});
  conn.sendNotification("textDocument/didOpen", {
    textDocument: { uri, languageId: "tsl", version: 1, text },
  });
  check("diagnostics on open: none", (await diagnosticsOf(1)).length === 0, published);

  const line = text.split("\n").findIndex((l) => l.startsWith("material white"));
  const edit = (version, replacement) =>
    conn.sendNotification("textDocument/didChange", {
      textDocument: { uri, version },
      contentChanges: [{ range: { start: { line, character: 17 }, end: { line, character: 24 } }, text: replacement }],
    });
  edit(2, "lambret");
  const errors = await diagnosticsOf(2);
  check("an error appears as it is typed", errors.length === 1 && /lambret/.test(errors[0].message), errors);
  edit(3, "lambert");
  check("and disappears when it is removed", (await diagnosticsOf(3)).length === 0, published);

  const hover = await conn.sendRequest("textDocument/hover", {
    textDocument: { uri },
    position: positionAfter("color dirt", "fbm"),
  });
  check("hover on fbm shows its documentation", /Fractional Brownian motion/.test(hover.contents.value), hover);

  const probe = "file://" + path.join(repo, "examples", "probe.tsl");
  const typed = "material probe = phong(";
  conn.sendNotification("textDocument/didOpen", {
    textDocument: { uri: probe, languageId: "tsl", version: 1, text: typed },
  });
  const items = await conn.sendRequest("textDocument/completion", {
    textDocument: { uri: probe },
    position: { line: 0, character: typed.length },
  });
  const labels = items.map((i) => i.label);
  check("completing phong( offers its parameters", ["kd:", "ks:", "ns:"].every((l) => labels.includes(l)), labels);

  const def = await conn.sendRequest("textDocument/definition", {
    textDocument: { uri },
    position: positionAfter("material wood =", "wood_rings"),
  });
  const target = fs.readFileSync(new URL(def.uri), "utf8").split("\n")[def.range.start.line];
  check("wood_rings is defined in the prelude", /generators\.tsl$/.test(def.uri) && /^float wood_rings\(/.test(target), def);

  const messy = "file://" + path.join(repo, "examples", "messy.tsl");
  conn.sendNotification("textDocument/didOpen", {
    textDocument: { uri: messy, languageId: "tsl", version: 1, text: "float  f(float x){return x*2;}" },
  });
  const edits = await conn.sendRequest("textDocument/formatting", {
    textDocument: { uri: messy },
    options: { tabSize: 4, insertSpaces: true },
  });
  check("formatting", edits.length === 1 && edits[0].newText === "float f(float x) {\n    return x * 2;\n}\n", edits);

  await conn.sendRequest("shutdown");
  conn.sendNotification("exit");
  const code = await new Promise((resolve) => child.on("exit", resolve));
  check("shutdown and exit", code === 0, code);
  conn.dispose();
}

main().catch((e) => {
  console.error(`FAIL ${e && e.stack ? e.stack : e}`);
  process.exit(1);
});
