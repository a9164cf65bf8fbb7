"""Networks of the model-free control system (Fig. 1): encoder f_ω, decoder g_ω̃, critic Q, actor μ.

Images enter as uint8 ``[N, H, W, 3]`` and are converted once per batch by :func:`to_float_chw`
(scaled to [0, 1], channels first), never per pixel in Python.

Two encoder/decoder shapes (``NetConfig.arch``):

* ``paper`` — the released code's stride-1, zero-padded 3×3 convolutions (channels 16→8→4 in the
  ``paper`` profile), flatten, dense to the 32-d latent φ with ReLU; the decoder mirrors it (dense to
  4·H·W, convolutions back to 3 channels, sigmoid output). About 3.8 M multiply-adds per 32×64 image.
* ``strided`` — the default: stride-2 3×3 convolutions (16→32→32) that halve the resolution at each
  layer (32×64 → 4×8), flatten, dense to φ; the decoder mirrors it with transposed convolutions.
  About 0.5 M multiply-adds per image, so per-step updates with a 64-sample batch fit a 2-core CPU
  budget (figures in docs/model-free.md).

The critic head is Q(φ, a) = W₂ ReLU(W₁ [φ, a]) (hidden 20, linear output); the actor is
μ(φ) = scale · tanh(W₂ act(W₁ φ)) (hidden 20) with the action scale a registered buffer, so it travels
with the weights and with an ONNX export.
"""

from __future__ import annotations

import torch
from torch import nn

from core.config import NetConfig

OBS_SHAPE: tuple[int, int, int] = (32, 64, 3)
"""Observation shape (H, W, C) of NicoGrasp: a 64×32 RGB image."""


def to_float_chw(obs: torch.Tensor) -> torch.Tensor:
    """uint8 ``[N, H, W, C]`` → float32 ``[N, C, H, W]`` in [0, 1] (the released code's scaling)."""
    return obs.permute(0, 3, 1, 2).float().div_(255.0)


class Encoder(nn.Module):
    """f_ω: image → latent φ (ReLU), Fig. 1(a)."""

    def __init__(self, config: NetConfig, obs_shape: tuple[int, int, int] = OBS_SHAPE) -> None:
        super().__init__()
        height, width, in_channels = obs_shape
        stride = 2 if config.arch == "strided" else 1
        layers: list[nn.Module] = []
        channels = in_channels
        for out_channels in config.conv_channels:
            layers += [nn.Conv2d(channels, out_channels, 3, stride=stride, padding=1), nn.ReLU()]
            channels = out_channels
            if stride == 2:
                height, width = (height + 1) // 2, (width + 1) // 2
        self.conv = nn.Sequential(*layers)
        self.feature_shape = (channels, height, width)
        self.fc = nn.Linear(channels * height * width, config.latent_dim)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        """``image``: float ``[N, C, H, W]`` in [0, 1]; returns φ ``[N, latent_dim]``."""
        return torch.relu(self.fc(self.conv(image).flatten(1)))


class Decoder(nn.Module):
    """g_ω̃: latent φ → reconstructed image in [0, 1] (sigmoid), Fig. 1(a)."""

    def __init__(self, config: NetConfig, encoder: Encoder, out_channels: int = 3) -> None:
        super().__init__()
        channels, height, width = encoder.feature_shape
        self.feature_shape = (channels, height, width)
        self.fc = nn.Linear(config.latent_dim, channels * height * width)
        layers: list[nn.Module] = []
        widths = [*reversed(config.conv_channels[:-1]), out_channels]
        for index, next_channels in enumerate(widths):
            if config.arch == "strided":
                layers.append(
                    nn.ConvTranspose2d(channels, next_channels, 3, stride=2, padding=1, output_padding=1)
                )
            else:
                layers.append(nn.Conv2d(channels, next_channels, 3, padding=1))
            if index < len(widths) - 1:
                layers.append(nn.ReLU())
            channels = next_channels
        self.deconv = nn.Sequential(*layers)

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        hidden = torch.relu(self.fc(latent)).view(-1, *self.feature_shape)
        return torch.sigmoid(self.deconv(hidden))


class Critic(nn.Module):
    """Q(φ, a | θ^Q): concat → hidden ReLU → linear value (Eq. 1)."""

    def __init__(self, config: NetConfig, action_dim: int) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Linear(config.latent_dim + action_dim, config.critic_hidden),
            nn.ReLU(),
            nn.Linear(config.critic_hidden, 1),
        )

    def forward(self, latent: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """Returns Q-values of shape ``[N]``."""
        return self.net(torch.cat([latent, action], dim=1)).squeeze(1)


class Actor(nn.Module):
    """μ(φ | θ^μ): hidden layer → tanh output scaled by the registered ``action_scale`` buffer, Fig. 1(b)."""

    action_scale: torch.Tensor

    def __init__(self, config: NetConfig, action_dim: int, action_scale: torch.Tensor | float = 1.0) -> None:
        super().__init__()
        activation: nn.Module = nn.Tanh() if config.actor_activation == "tanh" else nn.ReLU()
        self.net = nn.Sequential(
            nn.Linear(config.latent_dim, config.actor_hidden),
            activation,
            nn.Linear(config.actor_hidden, action_dim),
            nn.Tanh(),
        )
        scale = torch.as_tensor(action_scale, dtype=torch.float32).expand(action_dim).clone()
        self.register_buffer("action_scale", scale)

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.net(latent) * self.action_scale


class PolicyNetwork(nn.Module):
    """Encoder + actor as one module: uint8 ``[N, H, W, 3]`` → action ``[N, action_dim]``.

    What gets deployed, exported to ONNX and aligned sim-to-real (Section 4.2).
    """

    def __init__(self, encoder: Encoder, actor: Actor) -> None:
        super().__init__()
        self.encoder = encoder
        self.actor = actor

    def forward(self, obs_uint8: torch.Tensor) -> torch.Tensor:
        return self.actor(self.encoder(to_float_chw(obs_uint8)))


def multiply_adds_per_image(encoder: Encoder, obs_shape: tuple[int, int, int] = OBS_SHAPE) -> int:
    """Multiply-adds of one encoder forward pass (for the docs' architecture comparison)."""
    height, width, _ = obs_shape
    total = 0
    for layer in encoder.conv:
        if isinstance(layer, nn.Conv2d):
            height = (height + 2 * layer.padding[0] - 3) // layer.stride[0] + 1
            width = (width + 2 * layer.padding[1] - 3) // layer.stride[1] + 1
            total += height * width * layer.out_channels * layer.in_channels * 9
    return total + encoder.fc.in_features * encoder.fc.out_features
