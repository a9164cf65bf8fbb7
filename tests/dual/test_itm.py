"""ITM (Section 2.3.1) on hand-made 2-D point sets: matching, edge adaptation, node adaptation/removal."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from core.dual.itm import InstantaneousTopologicalMap


def _map(points: list[tuple[float, float]], e_max: float = 1.0, distance: str = "l2", capacity: int = 64):
    return InstantaneousTopologicalMap(
        dim=2, e_max=e_max, distance=distance, initial_capacity=capacity, initial_weights=np.array(points)
    )


def test_starts_with_two_connected_nodes_at_first_stimulus() -> None:
    itm = InstantaneousTopologicalMap(dim=2, e_max=1.0)
    assert itm.num_nodes == 0
    events = itm.update(np.array([0.5, -1.0]))
    assert itm.num_nodes == 2
    assert events.added == (0, 1)
    assert itm.edges() == {(0, 1)}
    np.testing.assert_allclose(itm.weights([0, 1]), [[0.5, -1.0], [0.5, -1.0]])


def test_matching_picks_nearest_and_second_nearest() -> None:
    itm = _map([(0.0, 0.0), (4.0, 0.0)], e_max=100.0)
    events = itm.update(np.array([3.0, 0.5]))
    assert (events.matched, events.second) == (1, 0)
    assert events.winner == 1 and events.added == () and events.removed == ()


def test_node_added_outside_thales_sphere_and_beyond_emax() -> None:
    itm = _map([(0.0, 0.0), (1.0, 0.0)], e_max=1.0)
    events = itm.update(np.array([0.0, 3.0]))
    # (w_n − φ)·(w_n′ − φ) = (0,−3)·(1,−3) = 9 > 0 and ‖φ − w_n‖ = 3 > 1.
    assert events.added == (2,) and events.parents == (0,) and events.winner == 2
    assert itm.edges() == {(0, 1), (0, 2)}
    np.testing.assert_allclose(itm.weights(2), [0.0, 3.0])


def test_no_node_inside_thales_sphere_even_when_far() -> None:
    itm = _map([(0.0, 0.0), (4.0, 0.0)], e_max=1.0)
    # (w_n − φ)·(w_n′ − φ) = (−1.9,−0.5)·(2.1,−0.5) < 0: φ lies between n and n′.
    events = itm.update(np.array([1.9, 0.5]))
    assert events.added == () and itm.num_nodes == 2


@pytest.mark.parametrize(("distance", "expect_node"), [("l2", False), ("squared", True)])
def test_emax_compares_l2_or_squared_distance(distance: str, expect_node: bool) -> None:
    itm = _map([(0.0, 0.0), (1.0, 0.0)], e_max=2.0, distance=distance)
    # ‖φ − w_n‖ = 1.5 < 2 but ‖φ − w_n‖² = 2.25 > 2; φ is outside the Thales sphere.
    events = itm.update(np.array([0.0, -1.5]))
    assert (events.added != ()) is expect_node


def test_edge_adaptation_connects_and_prunes_and_removes_orphans() -> None:
    itm = _map([(0.0, 0.0), (6.0, 0.0)], e_max=1.0)
    assert itm.update(np.array([2.9, 4.0])).added == (2,)  # Q, edge to node 0
    assert itm.update(np.array([2.9, 5.5])).added == (3,)  # R, edge to Q
    assert itm.update(np.array([2.9, 2.5])).added == (4,)  # P (inside the circle on 0–1), edge to Q
    assert itm.edges() == {(0, 1), (0, 2), (2, 3), (2, 4)}
    events = itm.update(np.array([0.5, 0.5]))
    assert (events.matched, events.second) == (0, 4)
    # P lies inside the Thales spheres through (0, 1) and (0, Q): both edges go; node 1 is left
    # without edges and is removed, Q keeps its other edges.
    assert events.removed == (1,)
    assert events.added == ()
    assert itm.edges() == {(0, 4), (2, 3), (2, 4)}
    assert not itm.is_alive(1) and itm.num_nodes == 4
    assert 1 not in set(itm.nearest(np.array([[6.0, 0.0], [5.0, 0.1]])).tolist())
    live = itm.alive_ids()  # the live nodes' adjacency (the aim's neighbour average) is edges() as a matrix
    links = itm.adjacency(live)
    pairs = zip(*np.nonzero(np.triu(links)), strict=True)
    assert {(int(live[i]), int(live[j])) for i, j in pairs} == itm.edges()
    assert (links == links.T).all() and not links.diagonal().any()


def test_freed_slot_is_reused_by_next_node() -> None:
    itm = _map([(0.0, 0.0), (6.0, 0.0)], e_max=1.0)
    for p in ([2.9, 4.0], [2.9, 5.5], [2.9, 2.5], [0.5, 0.5]):
        itm.update(np.array(p))
    events = itm.update(np.array([-3.0, 0.0]))
    assert events.added == (1,) and events.parents == (0,)
    np.testing.assert_allclose(itm.weights(1), [-3.0, 0.0])
    assert (0, 1) in itm.edges()


def test_capacity_grows_and_ids_stay_stable() -> None:
    itm = _map([(0.0, 0.0), (1.0, 0.0)], e_max=0.5, capacity=2)
    xs = [2.0, 3.0, 4.0, 5.0, 6.0]
    for x in xs:
        itm.update(np.array([x, 0.0]))
    assert itm.num_nodes == 7 and itm.capacity >= 7
    np.testing.assert_allclose(itm.weights([0, 1, 2, 6]), [[0, 0], [1, 0], [2, 0], [6, 0]])
    # A chain: each new node hangs off the previous end.
    assert itm.edges() == {(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 6)}


def test_nearest_is_batched_and_matches_brute_force() -> None:
    rng = np.random.default_rng(0)
    itm = InstantaneousTopologicalMap(dim=5, e_max=0.8)
    for x in rng.normal(size=(200, 5)):
        itm.update(x)
    queries = rng.normal(size=(64, 5))
    ids = itm.alive_ids()
    brute = ids[np.argmin(((queries[:, None, :] - itm.weights(ids)[None]) ** 2).sum(-1), axis=1)]
    np.testing.assert_array_equal(itm.nearest(queries), brute)
    np.testing.assert_array_equal(itm.nearest(torch.from_numpy(queries).float()), itm.nearest(queries))


def test_state_dict_round_trip() -> None:
    rng = np.random.default_rng(1)
    itm = InstantaneousTopologicalMap(dim=3, e_max=0.5)
    for x in rng.normal(size=(50, 3)):
        itm.update(x)
    other = InstantaneousTopologicalMap(dim=3, e_max=0.5)
    other.load_state_dict(itm.state_dict())
    assert other.edges() == itm.edges()
    q = rng.normal(size=(10, 3))
    np.testing.assert_array_equal(other.nearest(q), itm.nearest(q))


@pytest.mark.parametrize("kwargs", [{"e_max": 0.0}, {"distance": "cosine"}, {"dim": 0}])
def test_bad_parameters_raise(kwargs: dict) -> None:
    base = {"dim": 2, "e_max": 1.0}
    with pytest.raises(ValueError):
        InstantaneousTopologicalMap(**(base | kwargs))


def test_wrong_stimulus_size_raises() -> None:
    itm = InstantaneousTopologicalMap(dim=3, e_max=1.0)
    with pytest.raises(ValueError, match="3 components"):
        itm.update(np.zeros(2))


def test_prune_idle_removes_nodes_that_stopped_winning_and_keeps_two() -> None:
    itm = _map([(0.0, 0.0), (10.0, 0.0)], e_max=1.0)
    for x in (20.0, 30.0):
        assert itm.update(np.array([x, 0.0])).added  # nodes 2, 3
    for _ in range(5):
        itm.update(np.array([30.0, 0.1]))  # node 3 keeps winning
    # Idle for more than 3 updates: 0 and 1 (7), 2 (6); 2 is the most recent winner of them and is spared.
    removed = itm.prune_idle(max_idle=3)
    assert removed == (0, 1)
    assert itm.alive_ids().tolist() == [2, 3] and itm.edges() == {(2, 3)}
    assert itm.prune_idle(max_idle=3) == ()  # never below two nodes
    # A pruned slot is reused by the next node.
    events = itm.update(np.array([-20.0, 0.0]))
    assert events.added and events.added[0] in removed


def test_update_without_growth_only_matches() -> None:
    itm = _map([(0.0, 0.0), (1.0, 0.0)], e_max=1.0)
    events = itm.update(np.array([0.0, 3.0]), grow=False)
    assert events.added == () and itm.num_nodes == 2
