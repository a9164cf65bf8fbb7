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

import itertools
import math

import torch
from torch import nn

from core.config import NetConfig
from core.envs.spec import EnvSpec

OBS_SHAPE: tuple[int, int, int] = (32, 64, 3)
"""Observation shape (H, W, C) of NicoGrasp: a 64×32 RGB image."""


def to_float_chw(obs: torch.Tensor) -> torch.Tensor:
    """uint8 ``[N, H, W, C]`` → float32 ``[N, C, H, W]`` in [0, 1] (the released code's scaling)."""
    return obs.permute(0, 3, 1, 2).float().div_(255.0)


class LatentHead(nn.Module):
    """The encoder's last activation: ReLU (Fig. 1, the paper) or LayerNorm + tanh (SAC-AE, Yarats et al.
    2019: a bounded latent, so that the actor reading it cannot be driven to saturation by its scale)."""

    def __init__(self, latent_dim: int, kind: str) -> None:
        super().__init__()
        self.kind = kind
        if kind == "layernorm_tanh":
            self.norm = nn.LayerNorm(latent_dim)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        if self.kind == "layernorm_tanh":
            return torch.tanh(self.norm(features))
        return torch.relu(features)


class Encoder(nn.Module):
    """f_ω: image → latent φ (ReLU, or LayerNorm + tanh), Fig. 1(a)."""

    def __init__(
        self, config: NetConfig, obs_shape: tuple[int, int, int] = OBS_SHAPE, latent: str = "relu"
    ) -> None:
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
        self.head = LatentHead(config.latent_dim, latent)
        self.latent_dim = config.latent_dim

    @staticmethod
    def prepare(obs: torch.Tensor) -> torch.Tensor:
        """Stored uint8 ``[N, H, W, C]`` → the network's input, float ``[N, C, H, W]`` in [0, 1]."""
        return to_float_chw(obs)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        """``image``: float ``[N, C, H, W]`` in [0, 1]; returns φ ``[N, latent_dim]``."""
        return self.head(self.fc(self.conv(image).flatten(1)))


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


def mlp(sizes: list[int], activation: type[nn.Module] = nn.ReLU) -> nn.Sequential:
    """Linear layers of ``sizes`` with ``activation`` between them and none after the last."""
    layers: list[nn.Module] = []
    for index, (width, out) in enumerate(itertools.pairwise(sizes)):
        layers.append(nn.Linear(width, out))
        if index < len(sizes) - 2:
            layers.append(activation())
    return nn.Sequential(*layers)


class Critic(nn.Module):
    """Q(φ, a | θ^Q): concat → hidden ReLU layers → linear value (Eq. 1)."""

    def __init__(self, latent_dim: int, action_dim: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.net = mlp([latent_dim + action_dim, *hidden, 1])

    def forward(self, latent: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """Returns Q-values of shape ``[N]``."""
        return self.net(torch.cat([latent, action], dim=1)).squeeze(1)


class TwinCritic(nn.Module):
    """Two independent critics Q₁, Q₂ (TD3, SAC: clipped double Q-learning, Fujimoto et al. 2018)."""

    def __init__(self, latent_dim: int, action_dim: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.q1 = Critic(latent_dim, action_dim, hidden)
        self.q2 = Critic(latent_dim, action_dim, hidden)

    def forward(self, latent: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """Returns both Q-values, shape ``[2, N]``."""
        return torch.stack([self.q1(latent, action), self.q2(latent, action)])


def _bounds_affine(
    obs_dim: int, obs_low: tuple[float, ...] | None, obs_high: tuple[float, ...] | None
) -> tuple[torch.Tensor, torch.Tensor]:
    """Offset and scale mapping each dimension with finite bounds to [-1, 1] (identity elsewhere)."""
    offset, scale = torch.zeros(obs_dim), torch.ones(obs_dim)
    if obs_low is not None and obs_high is not None:
        low = torch.as_tensor(obs_low, dtype=torch.float32)
        high = torch.as_tensor(obs_high, dtype=torch.float32)
        offset, scale = (high + low) / 2, torch.clamp((high - low) / 2, min=1e-8)
    return offset, scale


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
        latent: str = "relu",
    ) -> None:
        super().__init__()
        offset, scale = _bounds_affine(obs_dim, obs_low, obs_high)
        self.register_buffer("offset", offset)
        self.register_buffer("scale", scale)
        layers: list[nn.Module] = []
        width = obs_dim
        for hidden in config.mlp_hidden:
            layers += [nn.Linear(width, hidden), nn.ReLU()]
            width = hidden
        self.mlp = nn.Sequential(*layers)
        self.fc = nn.Linear(width, config.latent_dim)
        self.head = LatentHead(config.latent_dim, latent)
        self.obs_dim = obs_dim
        self.latent_dim = config.latent_dim

    def prepare(self, obs: torch.Tensor) -> torch.Tensor:
        """Stored vectors ``[N, D]`` (any real dtype) → float32, scaled to [-1, 1] by the bounds."""
        return (obs.float() - self.offset) / self.scale

    def forward(self, vector: torch.Tensor) -> torch.Tensor:
        """``vector``: prepared float ``[N, D]``; returns φ ``[N, latent_dim]``."""
        return self.head(self.fc(self.mlp(vector)))


class ScaledObservation(VectorEncoder):
    """No learned encoder (``net.encoder = none``): φ is the observation scaled to [-1, 1] by its finite
    bounds, so actor and critic are the textbook MLPs on the observation (SB3's MlpPolicy, CleanRL)."""

    def __init__(
        self,
        obs_dim: int,
        obs_low: tuple[float, ...] | None = None,
        obs_high: tuple[float, ...] | None = None,
    ) -> None:
        nn.Module.__init__(self)
        offset, scale = _bounds_affine(obs_dim, obs_low, obs_high)
        self.register_buffer("offset", offset)
        self.register_buffer("scale", scale)
        self.obs_dim = self.latent_dim = obs_dim

    def forward(self, vector: torch.Tensor) -> torch.Tensor:
        return vector


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
"""Any encoder (ScaledObservation is a VectorEncoder); each has ``prepare(stored obs) -> input``,
``forward(input) -> φ`` and ``latent_dim``."""


def make_encoder(config: NetConfig, spec: EnvSpec, ac: str = "ddpg") -> ObservationEncoder:
    """The encoder f_ω the observation's kind and ``net.encoder`` call for (images: convolutional; vectors: an
    MLP, or none); its last activation is ``net.latent_activation`` resolved for actor-critic ``ac``; vectors
    are scaled by their bounds unless ``net.observation_scaling = none``."""
    latent = resolved_latent_activation(config, ac)
    if spec.obs_kind == "image":
        if config.encoder == "none":
            raise ValueError("net.encoder=none is for vector observations; images need the learned encoder")
        return Encoder(config, tuple(spec.obs_shape), latent)  # type: ignore[arg-type]
    low, high = (spec.obs_low, spec.obs_high) if config.observation_scaling == "bounds" else (None, None)
    if config.encoder == "none":
        return ScaledObservation(int(spec.obs_shape[0]), low, high)
    return VectorEncoder(config, int(spec.obs_shape[0]), low, high, latent)


def resolved_latent_activation(config: NetConfig, ac: str) -> str:
    """``net.latent_activation``, with ``auto`` → ReLU for DDPG/CACLA (the paper), LayerNorm + tanh for
    TD3/SAC (SAC-AE's bounded latent)."""
    if config.latent_activation != "auto":
        return config.latent_activation
    return "layernorm_tanh" if ac in ("td3", "sac") else "relu"


def make_decoder(config: NetConfig, encoder: ObservationEncoder, spec: EnvSpec) -> nn.Module | None:
    """The decoder g_ω̃ mirroring ``encoder``; None without a learned encoder (nothing to reconstruct)."""
    if isinstance(encoder, Encoder):
        return Decoder(config, encoder, out_channels=int(spec.obs_shape[2]))
    if isinstance(encoder, ScaledObservation):
        return None
    return VectorDecoder(config, encoder.obs_dim)


def head_sizes(config: NetConfig, spec: EnvSpec) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Hidden layers of (actor, critic): the paper's one-layer heads on a learned latent, or
    ``net.mlp_hidden`` for both when there is no encoder (the textbook networks)."""
    if config.encoder == "none" and spec.obs_kind != "image":
        return tuple(config.mlp_hidden), tuple(config.mlp_hidden)
    return (config.actor_hidden,), (config.critic_hidden,)


def make_actor(config: NetConfig, spec: EnvSpec, ac: str, latent_dim: int) -> Actor:
    """The actor of actor-critic ``ac``: deterministic μ(φ) (DDPG, CACLA, TD3) or squashed Gaussian (SAC)."""
    hidden, _ = head_sizes(config, spec)
    if ac == "sac":
        return SquashedGaussianActor(
            latent_dim, spec.action_dim, hidden, config.actor_activation, config.sac_log_prob
        )
    return Actor(latent_dim, spec.action_dim, hidden, config.actor_activation)


class Actor(nn.Module):
    """μ(φ | θ^μ): hidden layers → tanh output in the normalised action space [-1, 1], Fig. 1(b)."""

    def __init__(self, latent_dim: int, action_dim: int, hidden: tuple[int, ...], activation: str) -> None:
        super().__init__()
        layer = nn.Tanh if activation == "tanh" else nn.ReLU
        self.net = nn.Sequential(*mlp([latent_dim, *hidden, action_dim], layer), nn.Tanh())
        self.action_dim = action_dim

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.net(latent)


LOG_STD_MIN, LOG_STD_MAX = -20.0, 2.0
"""Bounds of the Gaussian's log standard deviation (SB3's and SAC's reference implementation)."""
SB3_SQUASH_EPSILON = 1e-6
"""SB3's floor inside log(1 − tanh(u)² + ε) (``sac_log_prob = sb3``)."""


class SquashedGaussianActor(Actor):
    """SAC's policy π(a | φ) = tanh(u), u ~ N(m(φ), σ(φ)²) (Haarnoja et al. 2018, Appendix C).

    ``forward`` is the deterministic action tanh(m(φ)) — what is deployed, exported and planned from;
    ``sample`` draws a ~ π with its log-probability (the change of variables of the tanh squashing).
    """

    def __init__(
        self,
        latent_dim: int,
        action_dim: int,
        hidden: tuple[int, ...],
        activation: str,
        log_prob: str = "exact",
    ) -> None:
        nn.Module.__init__(self)
        layer = nn.Tanh if activation == "tanh" else nn.ReLU
        self.log_prob_arithmetic = log_prob
        self.trunk = nn.Sequential(*mlp([latent_dim, *hidden], layer), layer())
        self.mean = nn.Linear(hidden[-1], action_dim)
        self.log_std = nn.Linear(hidden[-1], action_dim)
        self.action_dim = action_dim

    def distribution(self, latent: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and clamped log-std of the Gaussian before the squashing, each ``[N, action_dim]``."""
        features = self.trunk(latent)
        return self.mean(features), self.log_std(features).clamp(LOG_STD_MIN, LOG_STD_MAX)

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.mean(self.trunk(latent)))  # `distribution`'s mean, without the unused log-std

    def sample(
        self, latent: torch.Tensor, noise: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """a = tanh(m + σ ε) with ε ~ N(0, I) (or ``noise``), and log π(a | φ) ``[N]``:
        log N(u; m, σ) − Σ log(1 − tanh(u)²) (Eq. 21 of Haarnoja et al. 2018), the last term as
        2 (log 2 − u − softplus(−2u)) for stability; or in SB3's arithmetic (``NetConfig.sac_log_prob``)."""
        mean, log_std = self.distribution(latent)
        eps = torch.randn_like(mean) if noise is None else noise
        u = mean + log_std.exp() * eps
        action = torch.tanh(u)
        if self.log_prob_arithmetic == "sb3":
            gaussian = torch.distributions.Normal(mean, log_std.exp()).log_prob(u).sum(dim=1)
            return action, gaussian - torch.log(1 - action.pow(2) + SB3_SQUASH_EPSILON).sum(dim=1)
        gaussian = (-0.5 * eps.pow(2) - log_std - 0.5 * math.log(2 * math.pi)).sum(dim=1)
        squash = (2 * (math.log(2.0) - u - nn.functional.softplus(-2 * u))).sum(dim=1)
        return action, gaussian - squash


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
