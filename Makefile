# Two set-up commands: `make demo` and `make test`. Both create .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test worlds bench clean browser xvfb

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m vismobile.app.demo

# Two test workers (pytest-xdist), each taking whole test files: a file's fixtures and the numba
# kernels it compiles stay in one process. TEST_WORKERS=0 runs in this process alone.
TEST_WORKERS ?= 2
test: $(STAMP) browser xvfb
	$(BIN)/python -m pytest $(if $(filter-out 0,$(TEST_WORKERS)),-n $(TEST_WORKERS) --dist loadfile)

# Debian's chromium for the report's browser test (tests/study/test_report_browser.py), installed
# only when missing and only as root with apt-get; elsewhere that test is skipped with the reason.
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    apt-get -o DPkg::Lock::Timeout=600 update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq \
	      --no-install-recommends chromium >/dev/null; \
	  else echo "chromium not installed (needs root and apt-get): the browser test is skipped"; fi; }

# Debian's xvfb (and xauth) for the viewer's real-window test (tests/viewer/test_window.py),
# installed only when missing and only as root with apt-get; elsewhere that test is skipped.
xvfb:
	@command -v Xvfb >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    apt-get -o DPkg::Lock::Timeout=600 update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq \
	      --no-install-recommends xvfb xauth >/dev/null; \
	  else echo "Xvfb not installed (needs root and apt-get): the viewer window test is skipped"; fi; }

worlds: $(STAMP)
	$(BIN)/vismobile worlds build --out worlds

clean:
	rm -rf $(VENV) out runs
