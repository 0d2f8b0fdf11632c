// Starts `tessera lsp` for scene files (*.tess) and stops it with the editor.
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const command = vscode.workspace.getConfiguration("tessera").get("path") || "tessera";
  const server = { command, args: ["lsp"] };
  client = new LanguageClient(
    "tessera",
    "tessera",
    { run: server, debug: server },
    { documentSelector: [{ language: "tessera" }] }
  );
  context.subscriptions.push(client);
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
