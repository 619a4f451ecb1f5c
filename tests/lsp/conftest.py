"""The language server under test: the real `knitc lsp` process, driven over stdio by
pytest-lsp's client, which also checks every message against the LSP specification.

`session` starts a server per test with VS Code's client capabilities (UTF-16 positions),
`neovim_session` with Neovim's; both in a fresh workspace folder (`tmp_path`).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import pytest_lsp
from lsp_session import Session, track_versions
from lsprotocol import types
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
SERVER = [sys.executable, "-m", "knitc.lsp"]


def _client(capabilities: str):
    @pytest_lsp.fixture(config=ClientServerConfig(server_command=SERVER))
    async def fixture(lsp_client: LanguageClient, tmp_path: Path, request: pytest.FixtureRequest):
        track_versions(lsp_client)
        marker = request.node.get_closest_marker("lsp_settings")
        await lsp_client.initialize_session(
            types.InitializeParams(
                capabilities=client_capabilities(capabilities),
                root_uri=tmp_path.as_uri(),
                workspace_folders=[types.WorkspaceFolder(tmp_path.as_uri(), "test")],
                initialization_options=marker.args[0] if marker else None,
            )
        )
        yield
        await lsp_client.shutdown_session()

    return fixture


vscode_client = _client("visual-studio-code")
neovim_client = _client("neovim")


@pytest.fixture
def session(vscode_client: LanguageClient, tmp_path: Path) -> Session:
    """A VS Code-like client (UTF-16 positions) on `knitc lsp`; settings from an
    `@pytest.mark.lsp_settings({...})` marker, as initializationOptions."""
    return Session(vscode_client, tmp_path)


@pytest.fixture
def neovim_session(neovim_client: LanguageClient, tmp_path: Path) -> Session:
    return Session(neovim_client, tmp_path)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "lsp_settings(options): the server's initializationOptions for the test"
    )


@pytest.fixture
def glove_text() -> str:
    return (EXAMPLES / "glove.knit").read_text(encoding="utf-8")
