"""The optimizer's square root: correctly rounded (the same bits on every CPU), with torch.sqrt's gradient."""

from __future__ import annotations

import numpy as np
import torch

from spark_bench.methods.ours import exact


def test_values_are_the_correctly_rounded_square_roots():
    values = np.random.default_rng(3).random(20_000).astype(np.float32) * np.float32(1e3)
    root = exact.sqrt(torch.from_numpy(values)).numpy()
    # a double's sqrt rounded to float is the correctly rounded float sqrt (53 >= 2 * 24 + 2 bits)
    rounded = np.sqrt(values.astype(np.float64)).astype(np.float32)
    assert root.dtype == np.float32 and np.array_equal(root, rounded)
    assert np.allclose(root, torch.sqrt(torch.from_numpy(values)).numpy(), rtol=1e-6)


def test_gradient_is_torch_sqrts_and_shapes_are_kept():
    x = torch.rand(4, 5, dtype=torch.float64) + 0.1
    assert torch.autograd.gradcheck(exact.sqrt, (x.clone().requires_grad_(True),))
    a, b = x.clone().requires_grad_(True), x.clone().requires_grad_(True)
    (exact.sqrt(a) * torch.arange(20.0, dtype=torch.float64).view(4, 5)).sum().backward()
    (torch.sqrt(b) * torch.arange(20.0, dtype=torch.float64).view(4, 5)).sum().backward()
    assert torch.allclose(a.grad, b.grad, rtol=1e-12)
    transposed = exact.sqrt(x.T)  # a strided view
    assert transposed.shape == (5, 4) and torch.allclose(transposed, torch.sqrt(x.T), rtol=1e-12)
    scalar = exact.sqrt(torch.tensor(6.25))
    assert scalar.shape == () and float(scalar) == 2.5
