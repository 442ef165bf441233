"""The robust objective (cadcam.solve.robust): its scenarios drawn as the simulated builds are,
each scenario's torque in the NLP against the simulated builds' model and against builds
evaluated exactly, its refusals, and a robust design of the tutorial's adjusted balancer."""
from pathlib import Path

import numpy as np
import pytest

import cadcam
from cadcam.errors import SpecError
from cadcam.problem import BUILD_KEYS, SOLVER
from cadcam.solve import robust
from cadcam.solve.transcription import Transcription
from cadcam.variation import directions, draws
from cadcam.verify import builds as B
from cadcam.verify.evaluate import evaluate, start_samples

from ..conftest import SPEC_RR

TUTORIAL = Path(__file__).resolve().parents[2] / "docs" / "first_balancer.toml"
#: The tutorial's adjusted arm (docs/tutorial.md, "Build it, and set it back"), a screw and a slot.
ADJUSTED = {"mechanisms.1.anchor_angle": 0.35, "adjustment.preload_travel": 0.0105, "adjustment.slot": "chi0",
            "adjustment.slot_travel": 0.12}


def _robust(scenarios: int, **more) -> cadcam.Problem:
    return cadcam.load_problem(TUTORIAL, overrides={**ADJUSTED, "solver.objective": "robust",
                                                    "builds.scenarios": scenarios, **more})


def test_the_robust_objective_is_declared_beside_the_nominal_ones():
    assert SOLVER["objective"].choices == ("least_squares", "minimax", "robust")
    assert SOLVER["objective"].default == "least_squares"
    assert {k.name: k.default for k in BUILD_KEYS.keys}.items() >= {"scenarios": 32, "tail": 0.1}.items()


def test_scenarios_are_drawn_as_builds_are_from_a_stream_of_their_own():
    """Each scenario's step is a draw over every tolerance's steps, the same for the same seed,
    another for another seed, and not one of the simulated builds (which re-check the design)."""
    problem = _robust(200)
    layout, _ = robust.scenario_layout(problem)
    steps = robust.scenario_steps(problem, layout)
    np.testing.assert_array_equal(steps, robust.scenario_steps(problem, layout))
    reseeded = _robust(200, **{"builds.seed": 1})
    assert not np.allclose(steps, robust.scenario_steps(reseeded, robust.scenario_layout(reseeded)[0]))
    D = np.concatenate(list(directions(problem, [pr.basis for pr in problem.profiles], layout)[0].values()), axis=1)
    xi = np.linalg.lstsq(D, steps, rcond=None)[0]  # the draws behind the steps
    np.testing.assert_allclose(D @ xi, steps, atol=1e-15)
    assert np.abs(xi).max() <= 1 and np.abs(xi).max() > 0.95  # uniform within ± each tolerance
    k = int(layout.start["k"])
    assert np.abs(steps[k]).max() <= 0.1 * 1000.0 and np.abs(steps[k]).max() > 0.095 * 1000.0  # ± 10 % of 1000 N/m
    simulated = draws(0, 200, D.shape[1], "uniform")
    assert not np.any(np.all(np.isclose(xi[:, :, None], simulated[:, None, :]), axis=0))


@pytest.mark.parametrize("spec,overrides,words", [
    (SPEC_RR, {}, "spring 2 joins several joints: use 'least_squares'"),
    (TUTORIAL, {"springs": []}, "designs for the builds of a design with springs; this one has none"),
])
def test_what_the_robust_objective_cannot_design_is_one_line(spec, overrides, words):
    data = cadcam.spec.read_spec_data(spec)
    data.update(overrides)
    if not data.get("springs"):
        data["joints"][0]["target"] = {"kind": "none"}
    problem = cadcam.spec.parse_spec(data, str(spec))
    with pytest.raises(SpecError, match=words) as err:
        robust.check_robust(problem.with_options(objective="robust"))
    assert "\n" not in str(err.value)


@pytest.fixture(scope="module")
def nominal():
    """The tutorial's adjusted arm designed as drawn (least squares), with its band's model."""
    result = cadcam.design(TUTORIAL, overrides=ADJUSTED)
    assert result.success
    return result


@pytest.mark.slow
def test_each_scenario_in_the_nlp_is_its_simulated_build(nominal):
    """The NLP's torque of the nominal design and of four scenarios, their settings set, against
    the design's and the simulated builds' model of the same steps
    (:class:`cadcam.verify.builds.BuildModel`): within 1e-6 of the target's peak without a
    setting, 2e-4 with a slot turned 7° (their curvatures from the slot's ends, each model's own
    quadrature); and against the builds evaluated exactly within 5e-4, as close as the builds'
    model comes (3e-4)."""
    problem = _robust(4)
    tr = Transcription(problem.with_options(functions="mapped"))
    ev, sens = nominal.evaluation, nominal.band.sensitivity
    w0, pv = tr.start_point(problem, nominal.design, start_samples(problem, nominal.design, tr.n, tr.start_order()))
    layout, chosen = robust.scenario_layout(problem)
    steps = robust.scenario_steps(problem, layout)
    peak = np.abs(ev.tau_d).max()
    model = B.build_model(ev, sens, B.mixed_function(sens.model), [s for s in chosen if not s.screw])[0]
    alpha = np.array([[0.0, 0.2, -0.1, 0.05], [0.0, -0.2, 0.2, 0.05]])  # screw, slot: shares of their ranges
    tr.v.put(w0, "ra", alpha.ravel(order="F"))
    moved = B.with_settings(steps, chosen, alpha * np.array([[s.bound] for s in chosen]))
    errors = np.asarray(tr._robust_fn(w0, pv)) * robust.ROBUST_UNIT * peak  # N·m
    np.testing.assert_allclose(errors[:, 0], (ev.tau - ev.tau_d).ravel(), atol=1e-6 * peak)  # the design itself
    np.testing.assert_allclose(errors[:, 1], model.error(moved)[:, 0], atol=1e-6 * peak)  # no setting
    np.testing.assert_allclose(errors[:, 1:], model.error(moved), atol=2e-4 * peak)
    exact = np.column_stack([(evaluate(*B.built(ev.problem, ev.design, sens.layout, s), grid=ev.grid,
                                       profile=False).tau - ev.tau_d).ravel() for s in moved.T])
    np.testing.assert_allclose(errors[:, 1:], exact, atol=5e-4 * peak)  # the builds' model: 3e-4
    assert np.abs(exact).max() > 0.02 * peak  # moved enough to tell


@pytest.mark.slow
def test_a_robust_design_lowers_its_builds_tail_and_holds_its_ranges(nominal):
    """Sixteen scenarios: the design succeeds, keeps the slot's and the screw's ranges as limits
    (nothing violated at their ends, which the nominal design's rows do not hold), and its ten
    thousand simulated builds, each at its best settings, have a lower P95 than the nominal
    design's (benchmarks/bench_robust.py has the numbers)."""
    result = cadcam.optimize(_robust(16))
    assert result.success and result.problem.options.objective == "robust"
    assert not result.builds.limits
    p95 = [r.builds.percentiles("best")[1, 0] for r in (result, nominal)]
    assert p95[0] < p95[1]
