"""MkDocs hook: serves cli.md, the command reference rendered from seagen's parsers at build time."""

from __future__ import annotations

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import File, Files

from seagen.cli.reference import render


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Add cli.md to the site's files (generated, never written into docs/, so it cannot go stale)."""
    files.append(File.generated(config, "cli.md", content=render()))
    return files
