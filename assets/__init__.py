"""The data camsim ships (installed as ``camsim_core.assets``): found with
:func:`camsim_core.datasets.asset_path`, never by a path of the checkout."""
