# Two commands set everything up on a fresh machine (Python >= 3.11 with venv):
#   make demo   runs the appliance on the bundled fixtures (no camera needed)
#   make test   runs the test suite (on two processes, then the timing tests alone: README "Test time")
# Each creates the virtual environment .venv on first use.
# Optional, as root, before them: make system-packages (Debian packages some tests and the GigE
# driver need: OpenCV's sample data, Aravis). Without them those tests skip and say why.

VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out
# The GigE extra (PyGObject) builds only where the GObject introspection headers are installed.
EXTRAS := test$(shell pkg-config --exists gobject-introspection-1.0 2>/dev/null && echo ,gige)
SYSTEM_PACKAGES := opencv-doc gir1.2-aravis-0.8 libgirepository1.0-dev libcairo2-dev pkg-config

.PHONY: demo test clean system-packages

$(BIN)/.installed: pyproject.toml
	python3 -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[$(EXTRAS)]'
	touch $@

SCENES := $(sort $(wildcard fixtures/scenes/left_*.png))

# The main job on the bundled fixtures: the run loop through the fake driver (MCAP log in
# $(OUT)/logs), the log's check, then each scene localized with an overlay and scored against truth.
demo: $(BIN)/.installed
	rm -rf $(OUT)/logs
	$(BIN)/appliance run --device fake:fixtures/scenes --calib fixtures/rig.yaml --log $(OUT)/logs
	$(BIN)/appliance logs check $(OUT)/logs/*.mcap
	for left in $(SCENES); do n=$${left##*left_}; n=$${n%.png}; \
	  $(BIN)/appliance localize --calib fixtures/rig.yaml $$left fixtures/scenes/right_$$n.png \
	    --json $(OUT)/result_$$n.json --overlay $(OUT)/overlay_$$n.png || exit 1; done
	$(BIN)/python -m appliance.synth.evaluate $(foreach l,$(SCENES),$(OUT)/result_$(subst left_,,$(basename $(notdir $(l)))).json fixtures/scenes/truth_$(subst left_,,$(basename $(notdir $(l)))).json)
	@echo "overlays: $(OUT)/overlay_*.png   log: $(OUT)/logs"

# The suite on two processes, then the tests that wait for real processes and real time on their own
# (tests/conftest.py: SERIAL); exit status 5 is "no test selected" (a PYTEST_ARGS subset).
test: $(BIN)/.installed
	$(BIN)/pytest -n 2 -m "not serial" $(PYTEST_ARGS) || [ $$? -eq 5 ]
	$(BIN)/pytest -m serial $(PYTEST_ARGS) || [ $$? -eq 5 ]

system-packages:
	apt-get update -q
	DEBIAN_FRONTEND=noninteractive apt-get install -y -q $(SYSTEM_PACKAGES)
	rm -f $(BIN)/.installed

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
