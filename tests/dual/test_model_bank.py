"""The stacked world-model bank equals a per-node loop of nn.Modules + torch.optim.Adam (Eq. 5, Eq. 8)."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from core.dual.model_bank import ModelBank

LATENT, ACTION, HIDDEN = 6, 2, 5


class _NodeModel(nn.Module):
    """The reference: one independent local model, as Section 4.1.1 describes it."""

    def __init__(self, bank: ModelBank, node: int) -> None:
        super().__init__()
        self.hidden = nn.Linear(LATENT + ACTION, HIDDEN)
        self.latent = nn.Linear(HIDDEN, LATENT)
        self.reward = nn.Linear(HIDDEN, 1)
        self.released = bank.output_activation == "released"
        with torch.no_grad():
            self.hidden.weight.copy_(bank.params["w1"][node].T)
            self.hidden.bias.copy_(bank.params["b1"][node])
            self.latent.weight.copy_(bank.params["wm"][node].T)
            self.latent.bias.copy_(bank.params["bm"][node])
            self.reward.weight.copy_(bank.params["wr"][node].T)
            self.reward.bias.copy_(bank.params["br"][node])

    def forward(self, phi: torch.Tensor, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = torch.tanh(self.hidden(torch.cat([phi, action], dim=-1)))
        nxt, r = self.latent(h), self.reward(h).squeeze(-1)
        if self.released:
            nxt, r = torch.sigmoid(nxt), torch.tanh(r)
        return nxt, r

    def flat(self) -> dict[str, torch.Tensor]:
        return {
            "w1": self.hidden.weight.T, "b1": self.hidden.bias, "wm": self.latent.weight.T,
            "bm": self.latent.bias, "wr": self.reward.weight.T, "br": self.reward.bias,
        }


def _bank(**kwargs) -> ModelBank:
    return ModelBank(latent_dim=LATENT, action_dim=ACTION, hidden=HIDDEN, lr=1e-2, initial_capacity=4,
                     generator=torch.Generator().manual_seed(3), **kwargs)


def _batch(ids: list[int], seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    n = len(ids)
    phi = torch.randn(n, LATENT, generator=g)
    action = torch.rand(n, ACTION, generator=g) * 2 - 1
    return torch.tensor(ids), phi, action, torch.randn(n, LATENT, generator=g), torch.randn(n, generator=g)


@pytest.mark.parametrize("activation", ["linear", "released"])
def test_batched_forward_equals_per_node_modules(activation: str) -> None:
    bank = _bank(output_activation=activation)
    bank.ensure_capacity(7)
    ids, phi, act, _, _ = _batch([0, 3, 3, 6, 1, 0])
    pred = bank.predict(ids, phi, act)
    for row, node in enumerate(ids.tolist()):
        ref_next, ref_r = _NodeModel(bank, node)(phi[row : row + 1], act[row : row + 1])
        torch.testing.assert_close(pred.next_latent[row], ref_next[0], atol=1e-6, rtol=0)
        torch.testing.assert_close(pred.reward[row], ref_r[0], atol=1e-6, rtol=0)


@pytest.mark.parametrize("activation", ["linear", "released"])
@pytest.mark.parametrize("norm", ["squared", "l2"])
def test_batched_update_equals_per_node_adam(activation: str, norm: str) -> None:
    bank = _bank(output_activation=activation, error_norm=norm)
    bank.ensure_capacity(6)
    nodes = [0, 2, 3, 5]
    refs = {n: _NodeModel(bank, n) for n in nodes}
    opts = {n: torch.optim.Adam(refs[n].parameters(), lr=1e-2) for n in nodes}
    untouched = {k: v[[1, 4]].clone() for k, v in bank.params.items()}
    # Two updates so the per-node step counts (bias correction) differ between nodes.
    for seed, ids in enumerate(([0, 0, 2, 5, 5, 5], [2, 3, 0])):
        ids_t, phi, act, nxt, rew = _batch(ids, seed=seed)
        expected_errors = []
        for row, node in enumerate(ids):
            with torch.no_grad():
                p_next, p_r = refs[node](phi[row : row + 1], act[row : row + 1])
            d_l, d_r = p_next[0] - nxt[row], p_r[0] - rew[row]
            expected_errors.append((d_l @ d_l + d_r * d_r) if norm == "squared" else d_l.norm() + d_r.abs())
        for node in sorted(set(ids)):
            rows = [i for i, n in enumerate(ids) if n == node]
            p_next, p_r = refs[node](phi[rows], act[rows])
            loss = (((p_next - nxt[rows]) ** 2).sum(-1) + (p_r - rew[rows]) ** 2).mean()
            opts[node].zero_grad()
            loss.backward()
            opts[node].step()
        errors = bank.update(ids_t, phi, act, nxt, rew)
        torch.testing.assert_close(errors, torch.stack(expected_errors), atol=1e-6, rtol=1e-6)
    for node in nodes:
        for k, ref in refs[node].flat().items():
            torch.testing.assert_close(bank.params[k][node], ref.detach(), atol=1e-6, rtol=0)
    for k, v in untouched.items():
        assert torch.equal(bank.params[k][[1, 4]], v)
    assert bank.steps.tolist()[:6] == [2, 0, 2, 1, 0, 1]


def test_capacity_grows_geometrically_and_keeps_parameters() -> None:
    bank = _bank()
    before = {k: v.clone() for k, v in bank.params.items()}
    bank.ensure_capacity(9)
    assert bank.capacity == 16
    for k, v in before.items():
        assert torch.equal(bank.params[k][:4], v)
    # New slots are freshly initialised, not zero.
    assert bank.params["w1"][9].abs().sum() > 0


def test_parent_init_copies_parent_and_resets_adam_state() -> None:
    bank = _bank(init="parent")
    ids, phi, act, nxt, rew = _batch([1, 1])
    bank.update(ids, phi, act, nxt, rew)
    bank.reset_nodes([3], parents=[1])
    for k in bank.params:
        assert torch.equal(bank.params[k][3], bank.params[k][1])
    assert bank.exp_avg[3].abs().sum() == 0 and bank.exp_avg_sq[3].abs().sum() == 0
    assert int(bank.steps[3]) == 0


def test_fresh_init_ignores_parent() -> None:
    bank = _bank(init="fresh")
    bank.reset_nodes([3], parents=[1])
    assert not torch.equal(bank.params["w1"][3], bank.params["w1"][1])


def test_update_lowers_error_on_repeated_sample() -> None:
    bank = _bank()
    ids, phi, act, nxt, rew = _batch([2])
    first = bank.update(ids, phi, act, nxt, rew)
    for _ in range(50):
        last = bank.update(ids, phi, act, nxt, rew)
    assert float(last) < 0.5 * float(first)


def test_state_dict_round_trip() -> None:
    bank = _bank()
    bank.update(*_batch([0, 1, 1]))
    other = _bank()
    other.load_state_dict(bank.state_dict())
    ids, phi, act, _, _ = _batch([0, 1, 2, 3], seed=5)
    expected = bank.predict(ids, phi, act).next_latent
    torch.testing.assert_close(other.predict(ids, phi, act).next_latent, expected)


def test_bad_options_and_shapes_raise() -> None:
    with pytest.raises(ValueError, match="init"):
        _bank(init="copy")
    with pytest.raises(ValueError, match="error_norm"):
        _bank(error_norm="l1")
    bank = _bank()
    ids, phi, act, nxt, rew = _batch([0, 1])
    with pytest.raises(ValueError, match="node ids"):
        bank.update(ids[:1], phi, act, nxt, rew)


class _DeltaModel(nn.Module):
    """The reference for the repaired model: reads (φ − μ)/s, φ̂′ = φ + s·M, a termination logit head."""

    def __init__(self, bank: ModelBank, node: int) -> None:
        super().__init__()
        self.base = _NodeModel(bank, node)
        self.done = nn.Linear(HIDDEN, 1)
        with torch.no_grad():
            self.done.weight.copy_(bank.params["wd"][node].T)
            self.done.bias.copy_(bank.params["bd"][node])
        self.scale, self.offset = bank.latent_scale, bank.latent_offset

    def forward(self, phi, action):
        x = torch.cat([(phi - self.offset) / self.scale, action], dim=-1)
        h = torch.tanh(self.base.hidden(x))
        latent = phi + self.scale * self.base.latent(h)
        return latent, self.base.reward(h).squeeze(-1), self.done(h).squeeze(-1)


@pytest.mark.parametrize("ids", [[1, 1, 1], [0, 2, 2, 3]])  # the one-node fast path and the general path
def test_delta_model_with_termination_head_in_normalised_units_equals_autograd(ids: list[int]) -> None:
    bank = _bank(target="delta", termination=True)
    bank.latent_scale = 0.3
    bank.latent_offset = torch.linspace(-1.0, 1.0, LATENT)
    bank.ensure_capacity(4)
    assert bank.params["wr"][0].abs().sum() == 0 and bank.params["br"][0].abs().sum() == 0  # r̂ starts at 0
    refs = {n: _DeltaModel(bank, n) for n in set(ids)}
    opts = {n: torch.optim.Adam([*refs[n].parameters()], lr=1e-2) for n in refs}
    ids_t, phi, act, nxt, rew = _batch(ids)
    done = torch.tensor([float(i % 2) for i in range(len(ids))])
    for node in refs:
        rows = [i for i, n in enumerate(ids) if n == node]
        p_next, p_r, logit = refs[node](phi[rows], act[rows])
        bce = torch.nn.functional.binary_cross_entropy_with_logits(logit, done[rows], reduction="none")
        loss = (((p_next - nxt[rows]) ** 2).sum(-1) + (p_r - rew[rows]) ** 2 + bce).mean()
        opts[node].zero_grad()
        loss.backward()
        opts[node].step()
    bank.update(ids_t, phi, act, nxt, rew, done)
    for node, ref in refs.items():
        for k, value in {**ref.base.flat(), "wd": ref.done.weight.T, "bd": ref.done.bias}.items():
            torch.testing.assert_close(bank.params[k][node], value.detach(), atol=1e-6, rtol=0)
        predicted = bank.predict(torch.tensor([node]), phi[:1], act[:1])
        with torch.no_grad():
            p_next, p_r, logit = ref(phi[:1], act[:1])
        torch.testing.assert_close(predicted.next_latent, p_next, atol=1e-5, rtol=0)
        torch.testing.assert_close(predicted.done, torch.sigmoid(logit), atol=1e-6, rtol=0)


def test_one_node_fast_path_equals_per_node_adam() -> None:
    bank = _bank(error_norm="l2")
    ref = _NodeModel(bank, 2)
    opt = torch.optim.Adam(ref.parameters(), lr=1e-2)
    for seed in range(3):
        ids, phi, act, nxt, rew = _batch([2, 2, 2, 2], seed=seed)
        p_next, p_r = ref(phi, act)
        loss = (((p_next - nxt) ** 2).sum(-1) + (p_r - rew) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        errors = bank.update(ids, phi, act, nxt, rew)
        torch.testing.assert_close(errors, (p_next - nxt).norm(dim=-1).detach() + (p_r - rew).abs().detach())
    for k, value in ref.flat().items():
        torch.testing.assert_close(bank.params[k][2], value.detach(), atol=1e-6, rtol=0)


def test_delta_needs_linear_outputs() -> None:
    with pytest.raises(ValueError, match="delta"):
        _bank(target="delta", output_activation="released")


def test_released_model_in_scaled_units_equals_autograd() -> None:
    """σ′ is taken at the sigmoid's output, not at φ̂′ = μ + s·σ (the two differ once s ≠ 1 or μ ≠ 0)."""
    bank = _bank(output_activation="released")
    bank.latent_scale, bank.latent_offset = 0.4, torch.linspace(-0.5, 0.5, LATENT)
    ref = _NodeModel(bank, 1)
    opt = torch.optim.Adam(ref.parameters(), lr=1e-2)
    for ids in ([1, 1, 1], [1, 0, 1]):  # the one-node path and the general path
        _, phi, act, nxt, rew = _batch(ids)
        rows = [i for i, n in enumerate(ids) if n == 1]
        out, r = ref((phi[rows] - bank.latent_offset) / bank.latent_scale, act[rows])
        latent = bank.latent_offset + bank.latent_scale * out
        loss = ((latent - nxt[rows]) ** 2).sum(-1) + (r - rew[rows]) ** 2
        opt.zero_grad()
        loss.mean().backward()
        opt.step()
        bank.update(torch.tensor(ids), phi, act, nxt, rew)
    for k, value in ref.flat().items():
        torch.testing.assert_close(bank.params[k][1], value.detach(), atol=1e-6, rtol=0)
