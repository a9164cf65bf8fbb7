"""Networks of the model-free control system (Fig. 1): encoder f_ω, decoder g_ω̃, critic Q, actor μ.

The observation's kind picks the encoder (``make_encoder``, SB3's rule: the space decides the extractor):

* images enter as uint8 ``[N, H, W, C]`` (any size) and are converted once per batch by
  :func:`to_float_chw` (scaled to [0, 1], channels first), never per pixel in Python; :class:`Encoder`
  is convolutional, in two shapes (``NetConfig.arch``):

  - ``paper`` — the released code's stride-1, zero-padded 3×3 convolutions (channels 16→8→4 in the
    ``paper`` profile), flatten, dense to the 32-d latent φ with ReLU; the decoder mirrors it (dense to
    4·H·W, convolutions back to C channels, sigmoid output). About 3.8 M multiply-adds per 32×64 image.
  - ``strided`` — the default: stride-2 3×3 convolutions (16→32→32) that halve the resolution at each
    layer (32×64 → 4×8), flatten, dense to φ; the decoder mirrors it with transposed convolutions.
    About 0.5 M multiply-adds per image, so per-step updates with a 64-sample batch fit a 2-core CPU
    budget (figures in docs/model-free.md).

* float vectors enter as ``[N, D]``; :class:`VectorEncoder` scales each dimension with finite bounds to
  [-1, 1] (a fixed affine map stored as buffers, so it travels with the weights and an ONNX export) and
  maps it through an MLP (``NetConfig.mlp_hidden``, ReLU) to φ with ReLU, like the image encoder's last
  layer; :class:`VectorDecoder` mirrors it with a linear output, so the critic-autoencoder's
  reconstruction loss (Eq. 4) compares it with the scaled vector.

The critic head is Q(φ, a) = W₂ ReLU(W₁ [φ, a]) (hidden 20, linear output); the actor is
μ(φ) = tanh(W₂ act(W₁ φ)) (hidden 20) in the agents' normalised action space [-1, 1]. The deployable
:class:`PolicyNetwork` ends in :class:`ActionBounds`, the map to the env's own bounds, so an export
answers in the env's units.
"""

from __future__ import annotations

import torch
from torch import nn

from core.config import NetConfig
from core.envs.spec import EnvSpec

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

    @staticmethod
    def prepare(obs: torch.Tensor) -> torch.Tensor:
        """Stored uint8 ``[N, H, W, C]`` → the network's input, float ``[N, C, H, W]`` in [0, 1]."""
        return to_float_chw(obs)

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


class VectorEncoder(nn.Module):
    """f_ω for float vector observations: bounds scaling to [-1, 1], MLP, ReLU latent φ (module docstring)."""

    offset: torch.Tensor
    scale: torch.Tensor

    def __init__(
        self,
        config: NetConfig,
        obs_dim: int,
        obs_low: tuple[float, ...] | None = None,
        obs_high: tuple[float, ...] | None = None,
    ) -> None:
        super().__init__()
        offset, scale = torch.zeros(obs_dim), torch.ones(obs_dim)
        if obs_low is not None and obs_high is not None:
            low = torch.as_tensor(obs_low, dtype=torch.float32)
            high = torch.as_tensor(obs_high, dtype=torch.float32)
            offset, scale = (high + low) / 2, torch.clamp((high - low) / 2, min=1e-8)
        self.register_buffer("offset", offset)
        self.register_buffer("scale", scale)
        layers: list[nn.Module] = []
        width = obs_dim
        for hidden in config.mlp_hidden:
            layers += [nn.Linear(width, hidden), nn.ReLU()]
            width = hidden
        self.mlp = nn.Sequential(*layers)
        self.fc = nn.Linear(width, config.latent_dim)
        self.obs_dim = obs_dim

    def prepare(self, obs: torch.Tensor) -> torch.Tensor:
        """Stored vectors ``[N, D]`` (any real dtype) → float32, scaled to [-1, 1] by the bounds."""
        return (obs.float() - self.offset) / self.scale

    def forward(self, vector: torch.Tensor) -> torch.Tensor:
        """``vector``: prepared float ``[N, D]``; returns φ ``[N, latent_dim]``."""
        return torch.relu(self.fc(self.mlp(vector)))


class VectorDecoder(nn.Module):
    """g_ω̃ for vectors: latent φ → the prepared (scaled) vector, MLP mirroring the encoder, linear output."""

    def __init__(self, config: NetConfig, obs_dim: int) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        width = config.latent_dim
        for hidden in reversed(config.mlp_hidden):
            layers += [nn.Linear(width, hidden), nn.ReLU()]
            width = hidden
        layers.append(nn.Linear(width, obs_dim))
        self.net = nn.Sequential(*layers)

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.net(latent)


ObservationEncoder = Encoder | VectorEncoder
"""Either encoder; both have ``prepare(stored obs) -> input`` and ``forward(input) -> φ``."""


def make_encoder(config: NetConfig, spec: EnvSpec) -> ObservationEncoder:
    """The encoder f_ω the observation's kind calls for (images: convolutional; vectors: MLP)."""
    if spec.obs_kind == "image":
        return Encoder(config, tuple(spec.obs_shape))  # type: ignore[arg-type]
    return VectorEncoder(config, int(spec.obs_shape[0]), spec.obs_low, spec.obs_high)


def make_decoder(config: NetConfig, encoder: ObservationEncoder, spec: EnvSpec) -> nn.Module:
    """The decoder g_ω̃ mirroring ``encoder``."""
    if isinstance(encoder, Encoder):
        return Decoder(config, encoder, out_channels=int(spec.obs_shape[2]))
    return VectorDecoder(config, encoder.obs_dim)


class Actor(nn.Module):
    """μ(φ | θ^μ): hidden layer → tanh output in the normalised action space [-1, 1], Fig. 1(b)."""

    def __init__(self, config: NetConfig, action_dim: int) -> None:
        super().__init__()
        activation: nn.Module = nn.Tanh() if config.actor_activation == "tanh" else nn.ReLU()
        self.net = nn.Sequential(
            nn.Linear(config.latent_dim, config.actor_hidden),
            activation,
            nn.Linear(config.actor_hidden, action_dim),
            nn.Tanh(),
        )
        self.action_dim = action_dim

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.net(latent)


class ActionBounds(nn.Module):
    """[-1, 1] → the env's [low, high] per dimension: ``low + (a + 1) / 2 · (high − low)``; the identity
    (no arithmetic at all) where the bounds are ±1. The bounds are buffers, so they travel with the
    weights and with an ONNX export (CleanRL's action scaling)."""

    low: torch.Tensor
    high: torch.Tensor

    def __init__(self, low: torch.Tensor | list[float], high: torch.Tensor | list[float]) -> None:
        super().__init__()
        self.register_buffer("low", torch.as_tensor(low, dtype=torch.float32).clone())
        self.register_buffer("high", torch.as_tensor(high, dtype=torch.float32).clone())
        self.identity = bool(torch.all(self.low == -1.0) and torch.all(self.high == 1.0))

    def forward(self, action: torch.Tensor) -> torch.Tensor:
        if self.identity:
            return action
        return self.low + (action + 1.0) * 0.5 * (self.high - self.low)


class PolicyNetwork(nn.Module):
    """Encoder + actor + action bounds as one module: stored observations ``[N, *obs_shape]`` (uint8 images
    or float vectors) → actions ``[N, action_dim]`` in the env's units.

    What gets deployed, exported to ONNX and aligned sim-to-real (Section 4.2).
    """

    def __init__(self, encoder: ObservationEncoder, actor: Actor, bounds: ActionBounds | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        self.actor = actor
        self.bounds = bounds or ActionBounds([-1.0] * actor.action_dim, [1.0] * actor.action_dim)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.bounds(self.actor(self.encoder(self.encoder.prepare(obs))))


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
