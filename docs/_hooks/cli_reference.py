"""MkDocs hook: the command-line reference, generated from the typer app at build time.

``docs/cli.md`` holds the marker ``<!-- cli-reference -->``; this hook replaces it with one
section per command (usage, help text, arguments and options) read from the click command
tree that ``hydropwa`` itself runs, so the page cannot drift from the code.
"""

from __future__ import annotations

import inspect
import re

MARKER = "<!-- cli-reference -->"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _param_rows(cmd, ctx) -> list[str]:
    rows = []
    for prm in cmd.get_params(ctx):
        if getattr(prm, "hidden", False):
            continue
        record = prm.get_help_record(ctx)
        if prm.param_type_name == "argument":
            name = "`" + (getattr(prm, "metavar", None) or prm.name).upper() + "`"
            kind = "argument" + ("" if prm.required else " (optional)")
            helptext = getattr(prm, "help", "") or ""
        elif record is None or record[0] == "--help":
            continue
        else:
            name = f"`{record[0]}`"
            kind = "option"
            helptext = record[1]
        rows.append(f"| {_cell(name)} | {kind} | {_cell(helptext)} |")
    return rows


def _render(cmd, path: list[str], ctx_parent, level: int) -> list[str]:
    import click

    ctx = click.Context(cmd, info_name=path[-1], parent=ctx_parent)
    name = " ".join(path)
    out = [f"{'#' * level} `{name}`", ""]
    doc = inspect.cleandoc(cmd.help or "")
    if doc:
        out += [doc, ""]
    pieces = re.sub(r"\{(\w+)\}", lambda m: m[1].upper(), " ".join(cmd.collect_usage_pieces(ctx)))
    out += ["```text", f"Usage: {name} {pieces}".rstrip(), "```", ""]
    rows = _param_rows(cmd, ctx)
    if rows:
        out += ["| name | kind | description |", "| --- | --- | --- |", *rows, ""]
    subs = getattr(cmd, "commands", None)
    if subs:
        for sub_name in sorted(subs):
            out += _render(subs[sub_name], [*path, sub_name], ctx, min(level + 1, 4))
    return out


def cli_reference() -> str:
    """Markdown for every command of ``hydropwa``."""
    import typer

    from hydropwa.cli import app

    root = typer.main.get_command(app)
    return "\n".join(_render(root, ["hydropwa"], None, 2))


def on_page_markdown(markdown, page, config, files):  # noqa: ARG001 - MkDocs hook signature
    if MARKER in markdown:
        return markdown.replace(MARKER, cli_reference())
    return markdown
