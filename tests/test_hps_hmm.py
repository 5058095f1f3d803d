"""ForwardStream.feed (block-diagonal, rescaled every few symbols) equals one
update per symbol, also when emission probabilities are tiny."""
import numpy as np
import pytest

from sw_hps.hmm import DiscreteHMM, ForwardStream


def banded(rng, n, m, tiny):
    a = np.triu(rng.random_sample((n, n))) * (np.subtract.outer(np.arange(n), np.arange(n)) >= -1)
    a /= a.sum(axis=1, keepdims=True)
    b = rng.random_sample((n, m)) + tiny
    b[:, ::2] = tiny          # half the symbols nearly impossible
    b /= b.sum(axis=1, keepdims=True)
    return DiscreteHMM(np.eye(n)[0], a, b)


@pytest.mark.parametrize("tiny", [1e-3, 1e-30, 1e-70])
def test_feed_equals_updates(tiny):
    rng = np.random.RandomState(3)   # legacy stream: same draws on the board's numpy 1.16
    models = [banded(rng, n, 8, tiny) for n in (2, 5, 7)]
    seq = rng.randint(0, 8, 1000)
    by_update = ForwardStream(models)
    for s in seq:
        by_update.update(int(s))
    fed = ForwardStream(models).feed(seq)
    assert np.isfinite(fed).all()
    np.testing.assert_allclose(fed, by_update.log_likelihoods(), rtol=1e-12)


def test_feed_continues_a_stream_and_keeps_impossible_models_impossible():
    rng = np.random.RandomState(4)
    b = np.full((3, 8), 1 / 7)
    b[:, 0] = 0.0             # symbol 0 impossible for this model
    models = [banded(rng, 3, 8, 1e-3), DiscreteHMM(np.eye(3)[0], np.eye(3), b)]
    seq = np.array([1, 2, 0, 3, 4, 5, 6, 7, 1])
    split = ForwardStream(models)
    split.feed(seq[:3])
    split.feed(seq[3:])
    whole = ForwardStream(models).feed(seq)
    np.testing.assert_allclose(split.log_likelihoods(), whole, rtol=1e-12)
    assert whole[1] == -np.inf and np.isfinite(whole[0])
    with pytest.raises(ValueError, match="symbols"):
        ForwardStream(models).feed([0, 8])
