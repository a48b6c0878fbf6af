from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VALIDATION = ROOT.parent / "shared" / "validation"


@pytest.fixture
def validation_dir():
    if not VALIDATION.exists():
        pytest.skip("shared/validation not found beside the checkout")
    return VALIDATION
