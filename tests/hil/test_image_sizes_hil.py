"""What an estimator costs in flash and RAM: the image built with and without it."""

import pytest

from vehil import profile
from vehil.build.budget import budget
from vehil.build.platformio import build_image


@pytest.mark.long
def test_an_estimator_s_footprint_is_the_difference_of_two_real_images(built) -> None:  # noqa: ANN001
    manf = profile.footprint("manf")
    alone = budget(build_image("manf"))  # passthrough and MANF only
    bare = budget(build_image("passthrough"))
    # its code, tables and helpers: more than its symbols alone, and within what an image
    # holding only it adds to the bare one (that also pays for the fixmath it pulls in)
    assert 3_000 < manf["flash"] <= alone.flash - bare.flash
    assert manf["ram"] == 0  # its state is smaller than the largest in the default union
    assert alone.static_ram < budget(build_image("all -ev_ekf -ev_ukf")).static_ram
