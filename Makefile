# Two commands set everything up on a fresh machine (Python >= 3.11 with venv):
#   make demo   runs the appliance on the bundled fixtures (no camera needed)
#   make test   runs the test suite
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

demo: $(BIN)/.installed
	$(BIN)/appliance config show

test: $(BIN)/.installed
	$(BIN)/pytest

system-packages:
	apt-get update -q
	DEBIAN_FRONTEND=noninteractive apt-get install -y -q $(SYSTEM_PACKAGES)
	rm -f $(BIN)/.installed

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
