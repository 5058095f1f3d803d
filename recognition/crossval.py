"""Cross-validation of the number of HMM states (thesis §8, Fig. 108).

For every candidate number of states and every fold, one set of class models
is trained on the other folds (:func:`recognition.hmm_train.train_models`) and
the held-out sequences are classified with
:meth:`sw_hps.hmm.GestureModels.classify`, the board's decision rule. The
(state count, fold) jobs are independent and run in parallel: on a local
process pool, on a given :class:`concurrent.futures.Executor`, or on a Dask
cluster (``scheduler="ADDRESS"``). Folds are fixed by the seed and every job
is deterministic, so the result does not depend on where the jobs ran.
"""
from __future__ import annotations

import json
import math
import os
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from recognition.hmm_train import MAX_STATES, train_models

__all__ = ["CVResult", "fold_assignment", "cross_validate", "write_cv_report"]


@dataclass(frozen=True)
class CVResult:
    """Outcome of :func:`cross_validate`.

    Attributes
    ----------
    state_counts : tuple of int
        The numbers of states tried, ascending.
    accuracy : tuple of float
        Per state count: correct held-out classifications / all samples.
    fold_accuracy : (len(state_counts), folds) float array
        Per state count and fold: correct / samples of that fold.
    fold_sizes : tuple of int
        Held-out samples per fold.
    best_states : int
        The state count with the highest accuracy (the smallest on ties).
    confusion : (C, C) int array
        Of ``best_states``: rows are the true class, columns the decision, in
        ``class_names`` order; rejected samples (no finite likelihood, or an
        empty sequence) are counted in ``rejected`` instead.
    rejected : (C,) int array
        Of ``best_states``: rejected samples per true class.
    predictions : (len(state_counts), samples) int array
        The decision for every sample (class index, -1 = rejected).
    class_names : tuple of str
    scheme : str
        ``"stratified"`` (k-fold) or ``"leave-one-group-out"``.
    fold_of : (samples,) int array
        The fold of each sample.
    groups : tuple or None
        Under leave-one-group-out, the group held out in each fold.
    seed : int
    train_options : dict
        The options passed to :func:`recognition.hmm_train.train_models`.
    """
    state_counts: tuple[int, ...]
    accuracy: tuple[float, ...]
    fold_accuracy: np.ndarray
    fold_sizes: tuple[int, ...]
    best_states: int
    confusion: np.ndarray
    rejected: np.ndarray
    predictions: np.ndarray
    class_names: tuple[str, ...]
    scheme: str
    fold_of: np.ndarray
    groups: tuple | None
    seed: int
    train_options: dict

    @property
    def folds(self) -> int:
        return len(self.fold_sizes)

    @property
    def best_accuracy(self) -> float:
        return self.accuracy[self.state_counts.index(self.best_states)]

    def to_dict(self) -> dict:
        """JSON-ready summary (no per-sample predictions)."""
        return {"scheme": self.scheme, "folds": self.folds, "seed": self.seed,
                "groups": None if self.groups is None else [_plain(g) for g in self.groups],
                "samples": int(self.predictions.shape[1]),
                "fold_sizes": list(self.fold_sizes),
                "class_names": list(self.class_names),
                "state_counts": list(self.state_counts),
                "accuracy": [float(a) for a in self.accuracy],
                "fold_accuracy": self.fold_accuracy.tolist(),
                "best_states": self.best_states,
                "best_accuracy": self.best_accuracy,
                "confusion": self.confusion.tolist(),
                "rejected": self.rejected.tolist(),
                "train_options": dict(self.train_options)}


def _plain(value):
    return value.item() if isinstance(value, np.generic) else value


def fold_assignment(labels, folds: int = 10, seed: int = 0, groups=None) -> np.ndarray:
    """Fold index of each sample.

    Stratified k-fold: the samples of each class are shuffled (``seed``) and
    dealt to the folds in turn, continuing across classes, so every fold gets
    each class in proportion and the fold sizes differ by at most one. With
    ``groups``: one fold per distinct group (sorted), leave-one-group-out.

    Raises
    ------
    ValueError
        ``folds`` outside [2, samples], or fewer than two groups.
    """
    labels = np.asarray([str(x) for x in labels])
    n = labels.size
    if groups is not None:
        groups = np.asarray(groups)
        if groups.shape != (n,):
            raise ValueError(f"groups must have one entry per sample ({n}), "
                             f"got shape {groups.shape}")
        distinct, fold_of = np.unique(groups, return_inverse=True)
        if distinct.size < 2:
            raise ValueError(f"groups must hold at least 2 distinct values for "
                             f"leave-one-group-out, got {distinct.size}")
        return fold_of.astype(np.int64)
    if isinstance(folds, bool) or not isinstance(folds, (int, np.integer)) \
            or not 2 <= folds <= max(n, 2):
        raise ValueError(f"folds must be an integer in [2, {max(n, 2)}] (the number of "
                         f"samples), got {folds!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    rng = np.random.default_rng(int(seed))
    fold_of = np.empty(n, dtype=np.int64)
    dealt = 0
    for name in sorted(set(labels.tolist())):
        members = rng.permutation(np.flatnonzero(labels == name))
        fold_of[members] = (dealt + np.arange(members.size)) % folds
        dealt += members.size
    return fold_of


def _run_job(data, train_index, test_index, class_names, num_states, train_options):
    """One (state count, fold) job: train on ``train_index``, classify
    ``test_index``; returns the decisions (class index, -1 = rejected)."""
    sequences, labels = data
    models = train_models([sequences[i] for i in train_index],
                          [labels[i] for i in train_index], class_names, num_states,
                          **train_options)
    decisions = np.empty(len(test_index), dtype=np.int64)
    for k, i in enumerate(test_index):
        seq = sequences[i]
        decisions[k] = models.classify(seq) if len(seq) else -1
    return decisions


class _Data:
    """Sequences and labels as one object (scattered once to a Dask cluster)."""

    def __init__(self, sequences, labels):
        self.sequences = sequences
        self.labels = labels

    def __iter__(self):
        return iter((self.sequences, self.labels))


def _check_state_counts(state_counts) -> tuple[int, ...]:
    values = list(state_counts) if not isinstance(state_counts, (str, bytes)) else [state_counts]
    if any(isinstance(c, bool) or not isinstance(c, (int, np.integer)) for c in values):
        raise ValueError(f"state_counts must be integers, got {values!r}")
    counts = tuple(sorted({int(c) for c in values}))
    if not counts or counts[0] < 1 or counts[-1] > MAX_STATES:
        raise ValueError(f"state_counts must be non-empty, each in [1, {MAX_STATES}], "
                         f"got {values!r}")
    return counts


def cross_validate(sequences, labels, state_counts, folds: int = 10, seed: int = 0,
                   groups=None, executor: Executor | None = None, progress=None, *,
                   scheduler: str | None = None, jobs: int | None = None,
                   class_names=None, **train_options) -> CVResult:
    """Cross-validated accuracy for each number of states (thesis Fig. 108).

    Parameters
    ----------
    sequences : list of 1-D integer arrays
        Symbol sequences (:func:`recognition.features.sequences`).
    labels : sequence of str
        Class of each sequence.
    state_counts : iterable of int
        Numbers of states to try, each in [1, 64].
    folds : int
        k of the stratified k-fold, in [2, samples]; ignored with ``groups``.
    seed : int
        Shuffles the samples into folds (the same seed gives the same folds).
    groups : sequence, optional
        A group per sample (e.g. the subject): leave-one-group-out instead.
    executor : concurrent.futures.Executor, optional
        Runs the jobs (left open). Default: a process pool of ``jobs``
        workers (the CPU count), or in this process if ``jobs == 1``.
    progress : callable, optional
        ``progress(done, total, num_states, fold, fold_accuracy)`` after each
        finished job.
    scheduler : str, optional
        Address of a running Dask scheduler (``"tcp://host:8786"``): the jobs
        go to its workers through a ``distributed.Client``, closed afterwards.
    jobs : int, optional
        Worker processes of the default pool.
    class_names : sequence of str, optional
        Model order (default: the sorted distinct labels).
    **train_options
        Passed to :func:`recognition.hmm_train.train_models` (``tol``,
        ``max_iter``, ``emission_floor``, ``expected_length``).

    Returns
    -------
    CVResult
        The accuracy over all held-out samples per state count (every sample
        is held out exactly once; rejected and empty sequences count as
        errors), per fold, and the confusion matrix of the best count.

    Raises
    ------
    ValueError
        Naming the bad parameter (``folds``, ``state_counts``, ``groups``,
        ``jobs``, ``scheduler``), or a class with fewer than 2 samples.
    """
    sequences = [np.asarray(s) for s in sequences]
    labels = [str(x) for x in labels]
    n = len(sequences)
    if len(labels) != n:
        raise ValueError(f"labels must have one entry per sequence ({n}), got {len(labels)}")
    names = tuple(sorted(set(labels))) if class_names is None \
        else tuple(str(c) for c in class_names)
    unknown = sorted(set(labels) - set(names))
    if unknown:
        raise ValueError(f"labels {unknown} are not in class_names {list(names)}")
    counts = _check_state_counts(state_counts)
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer))
                             or jobs < 1):
        raise ValueError(f"jobs must be an integer >= 1, got {jobs!r}")
    if scheduler is not None and executor is not None:
        raise ValueError("give either executor or scheduler, not both")
    fold_of = fold_assignment(labels, folds, seed, groups)
    num_folds = int(fold_of.max()) + 1
    for name in names:
        if labels.count(name) < 2:
            raise ValueError(f"class {name!r} has {labels.count(name)} sample(s): every class "
                             "needs at least 2 for cross-validation")
    fold_groups = None
    if groups is not None:
        fold_groups = tuple(_plain(g) for g in np.unique(np.asarray(groups)))
    label_index = np.array([names.index(x) for x in labels], dtype=np.int64)
    splits = [(np.flatnonzero(fold_of != f), np.flatnonzero(fold_of == f))
              for f in range(num_folds)]
    for f, (train, _) in enumerate(splits):
        missing = sorted(set(labels) - {labels[i] for i in train})
        if missing:
            where = f"group {fold_groups[f]!r}" if fold_groups else f"fold {f}"
            raise ValueError(f"holding out {where} leaves class(es) {missing} without "
                             "training samples")
    tasks = [(c, f) for c in counts for f in range(num_folds)]
    options = dict(train_options)
    data = _Data(sequences, labels)

    predictions = np.full((len(counts), n), -1, dtype=np.int64)
    fold_accuracy = np.zeros((len(counts), num_folds))
    done = 0

    def record(task, decisions):
        nonlocal done
        c, f = task
        test = splits[f][1]
        predictions[counts.index(c), test] = decisions
        fold_accuracy[counts.index(c), f] = float(np.mean(decisions == label_index[test]))
        done += 1
        if progress is not None:
            progress(done, len(tasks), c, f, float(fold_accuracy[counts.index(c), f]))

    def arguments(task, payload):
        c, f = task
        train, test = splits[f]
        return payload, train, test, names, c, options

    if scheduler is not None:
        _run_on_dask(scheduler, tasks, data, arguments, record)
    elif executor is not None:
        _run_on_executor(executor, tasks, data, arguments, record)
    elif jobs == 1:
        for task in tasks:
            record(task, _run_job(*arguments(task, data)))
    else:
        workers = min(jobs or os.cpu_count() or 1, len(tasks))
        with ProcessPoolExecutor(max_workers=workers) as pool:
            _run_on_executor(pool, tasks, data, arguments, record)

    correct = predictions == label_index[None, :]
    accuracy = tuple(float(x) for x in correct.mean(axis=1))
    best = counts[int(np.argmax(accuracy))]          # first maximum: fewest states
    row = predictions[counts.index(best)]
    c = len(names)
    confusion = np.zeros((c, c), dtype=np.int64)
    taken = row >= 0
    np.add.at(confusion, (label_index[taken], row[taken]), 1)
    rejected = np.bincount(label_index[~taken], minlength=c).astype(np.int64)
    return CVResult(counts, accuracy, fold_accuracy,
                    tuple(int((fold_of == f).sum()) for f in range(num_folds)), best,
                    confusion, rejected, predictions, names,
                    "leave-one-group-out" if groups is not None else "stratified",
                    fold_of, fold_groups, int(seed), options)


def _run_on_executor(executor, tasks, data, arguments, record):
    futures = {executor.submit(_run_job, *arguments(task, data)): task for task in tasks}
    try:
        for future in as_completed(futures):
            record(futures[future], future.result())
    except BaseException:
        for future in futures:
            future.cancel()
        raise


@contextmanager
def dask_client(address: str):
    """A ``distributed.Client`` of the scheduler at ``address``, closed on exit;
    ValueError (one line) if the package is missing or the scheduler cannot be
    reached."""
    try:
        from distributed import Client
    except ImportError:
        raise ValueError("scheduler needs the 'distributed' package (pip install "
                         "'dask[distributed]')") from None
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise ValueError(f"scheduler {address!r}: cannot connect ({exc})") from None
    try:
        yield client
    finally:
        client.close()


def _run_on_dask(address, tasks, data, arguments, record):
    from distributed import as_completed as dask_completed
    with dask_client(address) as client:
        payload = client.scatter(data, broadcast=True)
        futures = {}
        for task in tasks:
            future = client.submit(_run_job, *arguments(task, payload), pure=False)
            futures[future] = task
        for future in dask_completed(list(futures)):
            record(futures[future], future.result())


def write_cv_report(result: CVResult, json_path, png_path) -> None:
    """Write the cross-validation report: JSON (:meth:`CVResult.to_dict`) and
    a PNG plot of the accuracy against the number of states (thesis Fig. 108),
    with the spread over the folds and the best count marked. Both files go
    through temporary names (never half-written)."""
    json_path, png_path = Path(json_path), Path(png_path)
    _atomic_write(json_path, lambda p: p.write_text(json.dumps(result.to_dict(), indent=1)
                                                     + "\n"))
    _atomic_write(png_path, lambda p: _plot(result, p))


def _atomic_write(path: Path, write) -> None:
    tmp = path.with_name(path.name + ".part")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _plot(result: CVResult, path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    counts = np.array(result.state_counts)
    accuracy = 100.0 * np.array(result.accuracy)
    per_fold = 100.0 * result.fold_accuracy
    fig = Figure(figsize=(6.4, 4.0), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    if result.folds > 1:
        ax.fill_between(counts, per_fold.min(axis=1), per_fold.max(axis=1), color="C0",
                        alpha=0.15, linewidth=0, label="range over folds")
    ax.plot(counts, accuracy, "o-", color="C0", label="accuracy (all held-out samples)")
    ax.plot([result.best_states], [100.0 * result.best_accuracy], "*", color="C3",
            markersize=14, label=f"best: {result.best_states} states, "
                                 f"{100.0 * result.best_accuracy:.1f} %")
    ax.set_xlabel("number of states")
    ax.set_ylabel("recognition accuracy (%)")
    scheme = (f"{result.folds}-fold cross-validation" if result.scheme == "stratified"
              else f"leave-one-group-out ({result.folds} groups)")
    ax.set_title(f"{scheme}, {result.predictions.shape[1]} gestures")
    if len(counts) <= 20:
        ax.set_xticks(counts)
    low = math.floor(min(accuracy.min(), per_fold.min()) / 10.0) * 10.0
    ax.set_ylim(max(0.0, low - 1), 101)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    fig.tight_layout()
    fig.savefig(path, format="png")
