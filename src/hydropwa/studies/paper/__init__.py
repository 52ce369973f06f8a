"""The paper study: data → identification → PWA → evaluation → HTML report, resumable by stage.

``run_paper_study(out)`` runs the paper's campaign on the virtual rig (or reads a measured
dataset folder) and writes a self-contained report folder → :class:`StudyResult`; bad inputs
raise :class:`StudyError`. ``write_report(out)`` renders ``index.html`` from a finished
study's folder. It builds on the library: the evaluation of Sec. VII is
:mod:`hydropwa.evaluation`. See ``docs/architecture_evaluation.md``.
"""

from ._report import write_report
from ._study import StudyError, StudyResult, run_paper_study

__all__ = ["StudyError", "StudyResult", "run_paper_study", "write_report"]
