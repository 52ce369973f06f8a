"""Fixtures of the identification tests; the synthetic-data helpers live in ident_support.py
(imported by name, since several test folders have a conftest module)."""

from ident_support import table_ii, truth  # noqa: F401  (fixtures)
