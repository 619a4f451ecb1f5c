// The knitc extension: starts `knitc lsp` (stdio) for .knit files and adds "Knit: Preview",
// which asks the server for the viewer's HTML page of a design and shows it beside the editor.
"use strict";

const fs = require("fs");
const os = require("os");
const path = require("path");
const vscode = require("vscode");
const { LanguageClient, TransportKind, ExecuteCommandRequest, State } = require("vscode-languageclient/node");

const SECTION = "knitc";
let client = null;
const previews = new Map(); // document URI -> its webview panel

/** The settings the server reads (the client-only `server` and `trace` are left out). */
function serverSettings() {
  const c = vscode.workspace.getConfiguration(SECTION);
  return {
    defines: c.get("defines", {}),
    include: c.get("include", []),
    maxStitches: c.get("maxStitches", 2000000),
  };
}

/** `~`, `${userHome}` and `${workspaceFolder}` in `knitc.server.path` (VS Code expands none of them). */
function expandPath(p) {
  const folders = vscode.workspace.workspaceFolders;
  const ws = folders && folders.length ? folders[0].uri.fsPath : "";
  let out = p.replace(/\$\{userHome\}/g, os.homedir()).replace(/\$\{workspaceFolder\}/g, ws);
  if (out === "~" || out.startsWith("~/")) out = os.homedir() + out.slice(1);
  return out;
}

function createClient() {
  const c = vscode.workspace.getConfiguration(SECTION);
  const command = expandPath(c.get("server.path", "knitc") || "knitc");
  const args = c.get("server.args", ["lsp"]);
  const serverOptions = { command, args, transport: TransportKind.stdio };
  const clientOptions = {
    documentSelector: [{ scheme: "file", language: "knit" }],
    synchronize: { configurationSection: SECTION },
    initializationOptions: { [SECTION]: serverSettings() },
  };
  return new LanguageClient(SECTION, "knitc", serverOptions, clientOptions);
}

async function startClient() {
  client = createClient();
  try {
    await client.start();
  } catch (err) {
    const c = vscode.workspace.getConfiguration(SECTION);
    const cmd = [c.get("server.path", "knitc"), ...c.get("server.args", ["lsp"])].join(" ");
    vscode.window.showErrorMessage(
      `knitc: could not start the language server \`${cmd}\` (${err && err.message ? err.message : err}). ` +
        "Install knitc (`pip install .` in the knitc repository) or set `knitc.server.path`."
    );
  }
}

async function stopClient() {
  const old = client;
  client = null;
  if (old && old.state !== State.Stopped) {
    try {
      await old.stop();
    } catch (_) {
      // a server that never started cannot be stopped
    }
  }
}

/** The knit document to preview: the explorer's or editor title's argument, else the active editor's. */
function targetUri(arg) {
  if (arg instanceof vscode.Uri) return arg;
  const editor = vscode.window.activeTextEditor;
  if (editor && editor.document.languageId === "knit") return editor.document.uri;
  return null;
}

async function renderPreview(uri, panel) {
  if (!client || !client.isRunning()) {
    vscode.window.showErrorMessage("knitc: the language server is not running (see the \"knitc\" output).");
    return false;
  }
  const result = await client.sendRequest(ExecuteCommandRequest.type, {
    command: "knitc.preview",
    arguments: [uri.toString()],
  });
  if (!result || !(result.path || result.uri)) {
    vscode.window.showWarningMessage(
      `knitc: ${path.basename(uri.fsPath)} does not compile far enough to preview; see the Problems panel.`
    );
    return false;
  }
  const file = result.path || vscode.Uri.parse(result.uri).fsPath;
  panel.webview.html = fs.readFileSync(file, "utf8");
  return true;
}

async function showPreview(arg) {
  const uri = targetUri(arg);
  if (!uri) {
    vscode.window.showInformationMessage("knitc: open a .knit file to preview it.");
    return;
  }
  const key = uri.toString();
  let panel = previews.get(key);
  if (panel) {
    panel.reveal(vscode.ViewColumn.Beside, true);
  } else {
    panel = vscode.window.createWebviewPanel(
      "knitPreview",
      `Preview ${path.basename(uri.fsPath)}`,
      { viewColumn: vscode.ViewColumn.Beside, preserveFocus: true },
      { enableScripts: true, retainContextWhenHidden: true }
    );
    panel.webview.html = "<!DOCTYPE html><p>Compiling…</p>";
    previews.set(key, panel);
    panel.onDidDispose(() => previews.delete(key));
  }
  try {
    await renderPreview(uri, panel);
  } catch (err) {
    vscode.window.showErrorMessage(`knitc: preview failed: ${err && err.message ? err.message : err}`);
  }
}

async function activate(context) {
  context.subscriptions.push(
    vscode.commands.registerCommand("knit.showPreview", showPreview),
    // An open preview follows its design: it is redrawn each time the file is saved.
    vscode.workspace.onDidSaveTextDocument((doc) => {
      const panel = previews.get(doc.uri.toString());
      if (panel) renderPreview(doc.uri, panel).catch(() => {});
    }),
    // A different server executable or arguments need a new server process; the other
    // settings reach the running server through workspace/didChangeConfiguration.
    vscode.workspace.onDidChangeConfiguration(async (e) => {
      if (e.affectsConfiguration(`${SECTION}.server`)) {
        await stopClient();
        await startClient();
      }
    }),
    { dispose: () => stopClient() }
  );
  await startClient();
}

function deactivate() {
  return stopClient();
}

module.exports = { activate, deactivate };
