"""Applications built on the library: studies that run the whole chain on a campaign.

:mod:`hydropwa.studies.paper` is the paper's study (``hydropwa paper``): data →
identification → PWA → evaluation → report. A study sits above the library it uses; the
library (:mod:`hydropwa.evaluation` and below) knows nothing of it. See
``docs/architecture_evaluation.md``.
"""
