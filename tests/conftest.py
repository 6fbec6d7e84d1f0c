import pytest

import multilatin as ml


@pytest.fixture(scope="session")
def b0() -> ml.Model:
    return ml.load_model("b0")
