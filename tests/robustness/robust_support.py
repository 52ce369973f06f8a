"""Shared settings of the robustness suite (imported by name; several test folders have a conftest)."""

from __future__ import annotations

import os

#: The active hypothesis profile: ``ci`` (default), ``long`` or ``dev`` (HYPOTHESIS_PROFILE).
PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")

#: Examples per physics property (each one is a short simulation).
PHYSICS_EXAMPLES = {"ci": 8, "dev": 3, "long": 150}.get(PROFILE, 8)
