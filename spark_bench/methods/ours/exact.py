"""A square root whose last bit is the same on every x86 CPU, for the optimizer's numbers.

``torch.sqrt`` runs MKL's vector square root, which is not correctly rounded: its last bit comes from an
approximate reciprocal-square-root instruction whose result differs between CPU implementations, even
with MKL's reproducible ``COMPATIBLE`` branch (:mod:`spark_bench.kernels`). NumPy's ``sqrt`` is the
correctly rounded IEEE one, the same bits everywhere (measured under emulated Intel and AMD CPUs by
``benchmarks/measure_kernels.py``); its gradient here is torch's own formula, ``grad / (2 sqrt(x))``.
"""

from __future__ import annotations

import numpy as np
import torch


class _Sqrt(torch.autograd.Function):
    @staticmethod
    def forward(ctx, tensor: torch.Tensor) -> torch.Tensor:
        values = tensor.detach().numpy()
        root = torch.from_numpy(np.sqrt(values, out=np.empty_like(values)))  # an array for 0-d tensors too
        ctx.save_for_backward(root)
        return root

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> torch.Tensor:
        (root,) = ctx.saved_tensors
        return grad / (2 * root)


def sqrt(tensor: torch.Tensor) -> torch.Tensor:
    """The correctly rounded square root of a CPU tensor, differentiable (``torch.sqrt``'s values and gradient
    up to the last bit).

    :param tensor: a CPU tensor of non-negative values
    """
    return _Sqrt.apply(tensor)
