"""The fit's optimizer: Adam with the arithmetic pinned (:func:`spark_bench.methods.ours.exact.sqrt`), so
that a fitted pivot does not depend on the CPU that ran it (:mod:`spark_bench.kernels`).
"""

from __future__ import annotations

import numpy as np
import torch

from spark_bench.methods.ours import exact


class Adam:
    """Adam (Kingma and Ba), the update of ``torch.optim.Adam`` with its default betas and eps, on a few
    tensors with a learning rate each (the optimizer's first use imports ``torch._dynamo``: seconds).

    :param tensors: leaf tensors with ``requires_grad``
    :param lrs: base learning rate of each
    """

    def __init__(self, tensors: list[torch.Tensor], lrs: list[float], betas=(0.9, 0.999), eps: float = 1e-8):
        self.tensors, self.lrs, self.betas, self.eps = tensors, lrs, betas, eps
        self.moments = [(torch.zeros_like(t), torch.zeros_like(t)) for t in tensors]
        self.steps = 0

    def zero_grad(self) -> None:
        for tensor in self.tensors:
            tensor.grad = None

    def step(self, scale: float = 1.0) -> None:
        """One update with every learning rate multiplied by ``scale``."""
        beta1, beta2 = self.betas
        self.steps += 1
        correction1, correction2 = 1 - beta1 ** self.steps, 1 - beta2 ** self.steps
        with torch.no_grad():
            for tensor, lr, (mean, square) in zip(self.tensors, self.lrs, self.moments):
                if tensor.grad is None:
                    continue
                mean.mul_(beta1).add_(tensor.grad, alpha=1 - beta1)
                square.mul_(beta2).addcmul_(tensor.grad, tensor.grad, value=1 - beta2)
                denom = (exact.sqrt(square) / np.sqrt(correction2)).add_(self.eps)
                tensor.addcdiv_(mean, denom, value=-lr * scale / correction1)
