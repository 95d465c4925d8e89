// The TSL extension: the grammar and language configuration are declared in
// package.json; this file only starts the language server, `tslc lsp`, over
// stdio (vscode-languageclient adds `--stdio`, which tslc accepts). The
// setting `tsl.importPaths` reaches the server as its `importPaths`
// initialization option. If tslc cannot be started, highlighting still works.
const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const config = vscode.workspace.getConfiguration("tsl");
  const command = config.get("server.path", "tslc");
  const server = { command, args: ["lsp"], transport: TransportKind.stdio };
  client = new LanguageClient(
    "tsl",
    "TSL language server",
    { run: server, debug: server },
    {
      documentSelector: [
        { scheme: "file", language: "tsl" },
        { scheme: "untitled", language: "tsl" },
      ],
      initializationOptions: { importPaths: config.get("importPaths", []) },
    }
  );
  client.start().catch((err) => {
    vscode.window.showWarningMessage(`TSL: could not start \`${command} lsp\`: ${err.message || err}`);
  });
  context.subscriptions.push({ dispose: () => client && client.stop() });
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
