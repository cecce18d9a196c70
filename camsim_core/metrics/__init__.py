"""Image quality metrics (chapter section 4.3 and the comparison of section 3.2).

* :mod:`.cielab` - CIELAB Delta E*ab and CIEDE2000 from XYZ (colour-science);
* :mod:`.s_cielab` - S-CIELAB (Zhang & Wandell);
* :mod:`.viewing` - how the rendered image is viewed: S-CIELAB's samples per degree;
* :mod:`.block` - registration and block-averaged Delta E*ab (Figure 1.13);
* :mod:`.real` - the real versus simulated Kodak DCS-200 comparison;
* :mod:`.sharpness` - ISO 12233 slanted-edge MTF, MTF50, MTF at Nyquist;
* :mod:`.snr` - SNR of uniform regions and against light level;
* :mod:`.chart` - per-patch CIEDE2000 on the Macbeth chart;
* :mod:`.similarity` - PSNR and SSIM (scikit-image).

Public names: :func:`delta_e`, :func:`scielab`, :func:`block_compare`.
"""

from .cielab import METHODS, delta_e, delta_e_lab, xyz_to_lab
from .s_cielab import (
    GAUSSIANS,
    OPPONENT_TO_XYZ,
    XYZ_TO_OPPONENT,
    display_samples_per_degree,
    filter_opponent,
    filtered_lab,
    samples_per_degree,
    scielab,
    scielab_filter,
)
from .viewing import DEFAULT_VIEWING, ORIGINAL_EXAMPLE_VIEWING, Viewing, parse_viewing, viewing_samples_per_degree
from .block import BlockComparison, Registration, block_average, block_compare, register
from .real import RealComparison, compare_real
from .chart import chart_delta_e, macbeth_delta_e, macbeth_patch_boxes, patch_map
from .similarity import psnr, ssim
from .snr import region_snr, snr, snr_db, snr_vs_light
from .sharpness import NYQUIST, EdgeMTF, edge_angle, edge_mtf, luminance_weights, mtf50, mtf_at, slanted_edge_mtf

__all__ = [
    "METHODS",
    "delta_e",
    "delta_e_lab",
    "xyz_to_lab",
    "scielab",
    "scielab_filter",
    "filter_opponent",
    "filtered_lab",
    "samples_per_degree",
    "display_samples_per_degree",
    "Viewing",
    "parse_viewing",
    "viewing_samples_per_degree",
    "DEFAULT_VIEWING",
    "ORIGINAL_EXAMPLE_VIEWING",
    "XYZ_TO_OPPONENT",
    "OPPONENT_TO_XYZ",
    "GAUSSIANS",
    "block_compare",
    "block_average",
    "register",
    "BlockComparison",
    "Registration",
    "compare_real",
    "RealComparison",
    "slanted_edge_mtf",
    "mtf50",
    "mtf_at",
    "edge_mtf",
    "edge_angle",
    "luminance_weights",
    "EdgeMTF",
    "NYQUIST",
    "region_snr",
    "snr",
    "snr_db",
    "snr_vs_light",
    "macbeth_delta_e",
    "chart_delta_e",
    "macbeth_patch_boxes",
    "patch_map",
    "psnr",
    "ssim",
]
