"""Uploads in a real browser: a file over the cap is refused with a message and the page stays connected;
a file within it arrives in pieces and is selected. ``camsim serve --no-upload`` offers no upload."""

import numpy as np
import pytest

from app_helpers import ARTIFACTS, Page, explorer_server, wait_until
from camsim_core.scene import Scene

pytestmark = pytest.mark.browser


def _file_input(page):
    return page.page.locator(".w-upload input[type=file]").first


def test_upload_over_the_cap_gets_a_message_and_the_page_stays_connected(browser, tmp_path):
    ARTIFACTS.mkdir(exist_ok=True)
    rng = np.random.default_rng(1)
    small = Scene(rng.uniform(0, 1, (100, 100, 31)), np.arange(400, 710, 10.0), name="pieces")
    np.savez(tmp_path / "pieces.npz", data=small.data, wavelengths=small.wavelengths)  # 2.5 MB: three 1 MiB pieces
    (tmp_path / "big.npz").write_bytes(bytes(5 * 2**20))
    with explorer_server(extra_args=["--max-upload-mb", "3"]) as url:
        page = Page(browser, url)
        _file_input(page).set_input_files(str(tmp_path / "big.npz"))
        text = wait_until(page.alert_text, what="a message about the upload over the cap")
        page.shot("upload-over-cap")
        assert "Upload refused: big.npz: is 5.0 MiB, more than the 3.0 MiB an upload may be" in text
        # still connected: a change still reaches the server and comes back
        page.type_number("w-noise", 3)
        s = page.wait_for(lambda s: s["params"]["noise_sigma"] == 3)
        assert s["mean_de"] > 0
        # a file within the cap arrives in pieces and becomes the scene
        _file_input(page).set_input_files(str(tmp_path / "pieces.npz"))
        s = page.wait_for(lambda s: s["params"]["scene"] == "upload:pieces")
        assert page.alert_text() == ""
        assert page.errors() == []
        page.close()


def test_no_upload_mode_offers_no_upload(browser):
    with explorer_server(extra_args=["--no-upload"]) as url:
        page = Page(browser, url)
        assert page.page.locator(".w-upload input[type=file]").count() == 0 or not page.page.locator(".w-upload").first.is_visible()
        assert "Upload a scene" not in page.page.inner_text("body")
        page.close()
