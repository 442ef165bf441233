"""What a design page parses again at every step of a slider is kept: a spec's TOML document (by
its text) and a target's function (by its law), each read getting a copy of its own."""
import numpy as np

from cadcam.spec import read_spec_data
from cadcam.targets import Target

SPEC = """name = "kept"
[[springs]]
rate = 1000.0
"""


def test_a_spec_read_again_is_its_own_copy_and_follows_its_file(tmp_path):
    path = tmp_path / "kept.toml"
    path.write_text(SPEC)
    first = read_spec_data(path, overrides=[("springs.1.rate", 1200.0)])
    first["springs"][0]["preload"] = 5.0  # a reader's edits stay its own
    again = read_spec_data(path)
    assert first["springs"][0]["rate"] == 1200.0
    assert again["springs"] == [{"rate": 1000.0}]
    path.write_text(SPEC.replace("1000.0", "900.0"))  # the file changed: read anew
    assert read_spec_data(path)["springs"] == [{"rate": 900.0}]


def test_a_target_law_builds_its_function_once_and_each_law_its_own():
    law = {"expression": "a*sin(theta)", "parameters": {"a": 2.0}}
    first, again = Target("expression", law).function(1, 0), Target("expression", dict(law)).function(1, 0)
    other = Target("expression", {**law, "parameters": {"a": 3.0}}).function(1, 0)
    assert first is again and other is not first
    theta = np.array([[0.3, 1.1]])
    np.testing.assert_allclose(np.asarray(first.map(2)(theta)).ravel(), 2.0 * np.sin(theta.ravel()), rtol=1e-15)
    np.testing.assert_allclose(np.asarray(other.map(2)(theta)).ravel(), 3.0 * np.sin(theta.ravel()), rtol=1e-15)
