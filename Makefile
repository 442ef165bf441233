# cadcam — the two commands a fresh machine needs are `make demo` and `make test`
# (`make lint` for ruff and mypy; .ci/run runs both).
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: app docs-images demo test test-slow lint bench convergence clean generated study-weights_1dof reproduce-johnston2023 reproduce-ludovico2021 reproduce-endo2010 reproduce-fedorov2018 check-energy

# cadcam (editable) with its dependencies — casadi, numpy, scipy, matplotlib, ezdxf, manifold3d,
# tqdm — and the extras dev (pytest, pytest-xdist, hypothesis, jsonschema, dask[distributed],
# cvxpy, setuptools, Playwright's client and the app extra: panel, tomlkit), lint (ruff, mypy)
# and step (build123d: camN.step); the design page's browser test drives Debian's chromium,
# installed here when it is missing (Playwright's own browser download is not used); the design
# page's templates are compiled ahead into the user's cache (about a minute), so that their first
# design on this machine loads a library instead of solving with expanded functions
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev,lint,step]'
	test -x /usr/bin/chromium || (apt-get update -qq && apt-get install -y -qq chromium)
	$(VENV)/bin/cadcam cache --build
	touch $(STAMP)

# the design page on http://127.0.0.1:5006 (cadcam app; Ctrl-C stops it)
app: $(STAMP)
	$(VENV)/bin/cadcam app

# the README's first design: a noncircular pulley balancing an arm (docs/first_balancer.toml)
demo: $(STAMP)
	$(VENV)/bin/cadcam design docs/first_balancer.toml -o out/first_balancer
	@echo "demo outputs: out/first_balancer/ (result.json, verification.md, *.png, cam1.dxf/.svg and the other workshop files)"

# one worker per core; a test module stays on one worker (its module fixtures are built once);
# the tests marked slow (designs too heavy for five minutes on two cores) are left to test-slow
test: $(STAMP)
	$(PY) -m pytest -q -n auto --dist loadfile -m "not slow"

# the tests marked slow, which CI runs after make test
test-slow: $(STAMP)
	$(PY) -m pytest -q -n auto --dist loadfile -m slow

# ruff (the rules in pyproject.toml: defects, not style) and mypy on the public API; both
# report before the target fails
lint: $(STAMP)
	$(VENV)/bin/ruff check .; ruff=$$?; $(VENV)/bin/mypy && exit $$ruff

# every benchmark script (benchmarks/run.py), its tables shown as they come and written, with the
# machine, date and commit, to benchmarks/results.md; the last line is its time against 5 minutes
bench: $(STAMP)
	$(PY) benchmarks/run.py

# every shipped spec by the NLP at grids 21/46/91 and its own and twice its order, from the default
# and random starts, within CPU-time budgets (benchmarks/bench_convergence.py; about an hour) → benchmarks/convergence.md
convergence: $(STAMP)
	$(PY) benchmarks/run.py --scripts bench_convergence.py --results benchmarks/convergence.md

# the files written from declarations in the code: result.schema.json's declared parts (torque
# models, design methods, target kinds, each mechanism's own keys) and docs/spec_reference.md
generated: $(STAMP)
	$(PY) -m cadcam.outputs.schema
	$(PY) -m cadcam.outputs.spec_reference

# the pictures of the README and the tutorial: the tutorial's design, drawn as cadcam draws it,
# and the figure of its conventions (docs/conventions_figure.py: the keys noted on that drawing)
docs-images: demo
	mkdir -p docs/images
	cp out/first_balancer/profile.png docs/images/first_balancer.png
	cp out/first_balancer/torque.png docs/images/first_balancer_torque.png
	$(PY) docs/conventions_figure.py

clean:
	rm -rf out .pytest_cache build *.egg-info

study-weights_1dof: $(STAMP)
	$(PY) studies/weights_1dof.py

reproduce-johnston2023: $(STAMP)
	$(PY) studies/johnston2023.py

reproduce-ludovico2021: $(STAMP)
	$(PY) studies/ludovico2021.py

reproduce-endo2010: $(STAMP)
	$(PY) studies/endo2010.py

reproduce-fedorov2018: $(STAMP)
	$(PY) studies/fedorov2018.py

check-energy: $(STAMP)
	$(PY) benchmarks/energy_check.py

STUDIES := sensitivity_pareto idler_placement basis_order spring_catalogue
.PHONY: $(addprefix study-,$(STUDIES))
$(addprefix study-,$(STUDIES)): study-%: $(STAMP)
	$(PY) studies/$*.py
