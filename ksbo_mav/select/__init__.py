"""Kernel selection: Nyström C_ree (Algorithm 1), order selection, dimension selection, prior designs."""

from ksbo_mav.select.cree import cree_exact, cree_nystrom, sample_columns
from ksbo_mav.select.design import lhs_design, local_box
from ksbo_mav.select.dims import (
    DimensionSelection, feature_importances, keep_dimensions, kernel_from_selection, select_dimensions,
    select_dimensions_for_orders,
)
from ksbo_mav.select.orders import OrderSelection, order_kernel_matrices, select_orders

__all__ = [
    "DimensionSelection", "OrderSelection", "cree_exact", "cree_nystrom", "feature_importances",
    "keep_dimensions", "kernel_from_selection", "lhs_design", "local_box", "order_kernel_matrices",
    "sample_columns", "select_dimensions", "select_dimensions_for_orders", "select_orders",
]
