# Two commands set everything up on a fresh machine (Python >= 3.11 with venv):
#   make demo   runs the appliance on the bundled fixtures (no camera needed)
#   make test   runs the test suite
# Each creates the virtual environment .venv on first use.

VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out

.PHONY: demo test clean

$(BIN)/.installed: pyproject.toml
	python3 -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

demo: $(BIN)/.installed
	$(BIN)/appliance config show

test: $(BIN)/.installed
	$(BIN)/pytest

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
