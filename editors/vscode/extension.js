// A minimal VS Code client for `rapidc lsp` (docs/editors.md): it starts the server over stdio for
// .rapid files and YAML programs (*.rapid.yaml, *.rapid.yml).
const { workspace } = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate() {
  const config = workspace.getConfiguration("rapid");
  const server = {
    command: config.get("server.command", "rapidc"),
    args: ["lsp", ...config.get("server.args", [])],
  };
  client = new LanguageClient("rapid", "RAPID language server", server, {
    documentSelector: [
      { scheme: "file", language: "rapid" },
      { scheme: "untitled", language: "rapid" },
      { scheme: "file", pattern: "**/*.rapid.{yaml,yml}" },
    ],
    initializationOptions: { lint: config.get("lint", true) },
  });
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
