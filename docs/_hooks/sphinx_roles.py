"""MkDocs hook: Sphinx cross-reference roles in docstrings become links (issue 49).

The package's numpydoc docstrings name other objects with Sphinx roles
(``:class:`~hydropwa.params.SystemParams```), which mkdocstrings leaves as text: the API pages
showed ``:class:`` before every name. This hook turns each rendered role into an autorefs
cross-reference (``optional``: a name the API pages do not document stays plain code, and
``mkdocs build --strict`` does not fail on it); a leading ``~`` shows the last component only,
as in Sphinx.
"""

from __future__ import annotations

import html
import re

#: ``:role:`` followed by the code span Markdown made of the backquoted target.
ROLE = re.compile(
    r":(?:py:)?(?:class|func|meth|attr|data|mod|exc|obj|const|type):<code>(~?)([\w.]+)(\(\))?</code>"
)


def link_roles(text: str) -> str:
    """Rendered HTML with every Sphinx role replaced by an optional autorefs reference."""

    def ref(m: re.Match[str]) -> str:
        tilde, target, call = m.group(1), m.group(2), m.group(3) or ""
        title = (target.rsplit(".", 1)[-1] if tilde else target) + call
        ident = html.escape(target, quote=True)
        return f'<autoref identifier="{ident}" optional><code>{html.escape(title)}</code></autoref>'

    return ROLE.sub(ref, text)


def on_page_content(html_text, page, config, files):  # noqa: ARG001 - MkDocs hook signature
    return link_roles(html_text)
