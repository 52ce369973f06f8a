"""The shortcuts of ``simulate``'s Python around the kernel give what the general calls give.

``simulate`` packs each frozen model's parameters once per command amplitude (unless the
model holds a writeable array) and checks a model class against the ``Model`` protocol once;
each must be invisible in the numbers (bit for bit).
"""

import numpy as np
import pytest

from hydropwa.models import FullOrderModel, ReducedModel
from hydropwa.simulation import _simulate as S
from hydropwa.simulation import simulate


def test_packed_parameters_are_the_models_own_in_a_fresh_copy(paper):
    full = FullOrderModel(paper)
    first = S._packed_params(full, 0.4)
    assert np.array_equal(first, full.pack(command_amplitude=0.4))
    first[:] = np.nan  # what a caller does to its copy reaches no later call
    assert np.array_equal(S._packed_params(full, 0.4), full.pack(command_amplitude=0.4))
    # ω0 follows the amplitude schedule (Table II): another amplitude is another vector
    small = S._packed_params(full, 0.05)
    assert np.array_equal(small, full.pack(command_amplitude=0.05))
    assert not np.array_equal(small, full.pack(command_amplitude=0.4))
    # an equal but distinct model with other parameters is packed from its own
    heavy = FullOrderModel(paper.replace(**{"load.mass": 2.0 * paper.load.mass}))
    assert np.array_equal(S._packed_params(heavy, 0.4), heavy.pack(command_amplitude=0.4))
    assert not np.array_equal(S._packed_params(heavy, 0.4), S._packed_params(full, 0.4))


def test_a_repeated_simulate_gives_the_first_ones_numbers(paper):
    """The second call takes the remembered model class and packed vector: the same run."""
    reduced = ReducedModel(paper)
    runs = [simulate(reduced, "sine:amplitude=0.4,frequency=1", duration=0.2) for _ in range(2)]
    assert type(reduced) in S._MODEL_CLASSES
    assert np.array_equal(runs[0].states, runs[1].states)
    assert runs[0].stats.omega0 == runs[1].stats.omega0
    other = simulate(
        ReducedModel(paper.replace(**{"load.mass": 2.0 * paper.load.mass})),
        "sine:amplitude=0.4,frequency=1",
        duration=0.2,
    )
    assert not np.array_equal(other.states, runs[0].states)


def test_a_model_with_writeable_arrays_is_packed_on_every_call(paper):
    """A PWA model's cell tables are NumPy arrays a caller can edit in place: its packed
    vector must follow the edit (no remembered copy), while the full model's is remembered."""
    import copy

    from hydropwa.linearization import linearize

    pwa = copy.deepcopy(linearize(paper))  # a deep copy's arrays are writeable again
    before = S._packed_params(pwa, 0.4)
    pwa.friction.pwa.offsets[:] += 1.0  # an in-place edit of a frozen model's table
    after = S._packed_params(pwa, 0.4)
    assert np.array_equal(after, pwa.pack(command_amplitude=0.4))
    assert not np.array_equal(after, before)
    assert all(key[0] != id(pwa) for key in S._PACKED)
    assert S._writeable_arrays(pwa) and not S._writeable_arrays(FullOrderModel(paper))


def test_linearized_models_are_read_only_and_remembered(paper):
    """The cell tables of the models ``linearize`` builds cannot be edited in place (an
    edit would also reach every model sharing the cached cell fits), so their packed vector
    is remembered like the full model's."""
    from hydropwa.linearization import linearize

    for pwa in (linearize(paper), linearize(paper, form="chamber")):
        assert not S._writeable_arrays(pwa)
        with pytest.raises(ValueError, match="read-only"):
            pwa.friction.pwa.offsets[0] = 0.0
        first = S._packed_params(pwa, 0.4)
        assert (id(pwa), 0.4) in S._PACKED
        assert np.array_equal(first, pwa.pack(command_amplitude=0.4))
