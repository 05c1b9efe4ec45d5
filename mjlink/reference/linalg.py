"""Many small linear systems at once: the kinetostatic solve of every variant and crank angle.

``numpy.linalg.solve`` on an (n, m, m) stack calls LAPACK once per matrix; for m = 9 that is
about 0.8 us each, mostly per-call overhead, and it was the largest single cost of a design
study's loads. A mechanism's kinetostatic matrix is sparse and the same pattern at every row:
each Assur group's equations involve only its own pairs and those of the groups it hangs on.
:func:`solve` permutes the pattern into block-triangular form once (a maximum matching puts a
structural nonzero on the diagonal; the strongly connected components of the result are the
diagonal blocks, solved in dependency order; both graph searches in plain Python, for tens of
unknowns, where scipy.sparse's would cost its import in every command), then solves every diagonal block for all rows
at once by Gaussian elimination with partial pivoting written as array operations across the
rows (the same algorithm as LAPACK's dgesv, vectorized the other way round), substituting the
solved unknowns into the later blocks. The plain twin is ``numpy.linalg.solve``; the two agree
to round-off (tested).
"""

from __future__ import annotations

import functools

import numpy as np

MAX_BLOCK = 12  # larger diagonal blocks go to LAPACK (the elimination's work grows as k^3)


@functools.lru_cache(maxsize=64)
def _plan(pattern_bytes: bytes, m: int) -> tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] | None:
    """The diagonal blocks (rows, unknowns) in solving order for a sparsity pattern, or None
    if the pattern is structurally singular."""
    pattern = np.frombuffer(pattern_bytes, dtype=bool).reshape(m, m)
    found = _matching(pattern)
    if found is None:
        return None
    match = np.array(found)
    P = pattern[:, match]  # row i's matched unknown is column i: a nonzero diagonal
    label = np.array(_components(P))
    count = int(label.max()) + 1 if m else 0
    # Component a needs component b if a row of a uses an unknown of b.
    needs: dict[int, set[int]] = {a: set() for a in range(count)}
    for i, j in zip(*np.nonzero(P), strict=True):
        if label[i] != label[j]:
            needs[int(label[i])].add(int(label[j]))
    order: list[int] = []
    done: set[int] = set()
    while len(order) < count:
        ready = [a for a in range(count) if a not in done and needs[a] <= done]
        if not ready:  # pragma: no cover - strongly connected components form a DAG
            return None
        for a in ready:
            order.append(a)
            done.add(a)
    blocks = []
    for a in order:
        rows = tuple(int(i) for i in np.flatnonzero(label == a))
        blocks.append((rows, tuple(int(match[i]) for i in rows)))
    return tuple(blocks)


def _matching(pattern: np.ndarray) -> list[int] | None:
    """A column for every row with a structural nonzero, no column twice (a maximum bipartite
    matching, Kuhn's augmenting paths: the systems have tens of unknowns), or None if there
    is none that covers every row."""
    m = len(pattern)
    cols_of = [np.flatnonzero(pattern[i]).tolist() for i in range(m)]
    row_of: list[int] = [-1] * m  # the row matched to each column
    for start in range(m):
        # Depth-first search for an augmenting path from row ``start``.
        seen = [False] * m
        stack = [(start, iter(cols_of[start]))]
        via: dict[int, int] = {}  # column -> the row it was reached from
        found = -1
        while stack and found < 0:
            row, it = stack[-1]
            for c in it:
                if seen[c]:
                    continue
                seen[c] = True
                via[c] = row
                if row_of[c] < 0:
                    found = c
                    break
                stack.append((row_of[c], iter(cols_of[row_of[c]])))
                break
            else:
                stack.pop()
        if found < 0:
            return None
        c = found
        while True:  # flip the path back to ``start``
            r = via[c]
            prev = next((k for k in range(m) if row_of[k] == r), -1)
            row_of[c] = r
            if r == start:
                break
            c = prev
    match = [0] * m
    for c, r in enumerate(row_of):
        match[r] = c
    return match


def _components(P: np.ndarray) -> list[int]:
    """Strongly connected component of every node of the directed graph i -> j where P[i, j]
    (Tarjan's algorithm, iterative)."""
    m = len(P)
    succ = [np.flatnonzero(P[i]).tolist() for i in range(m)]
    index = [-1] * m
    low = [0] * m
    on_stack = [False] * m
    label = [-1] * m
    stack: list[int] = []
    counter = count = 0
    for root in range(m):
        if index[root] >= 0:
            continue
        work = [(root, iter(succ[root]))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack[root] = True
        while work:
            v, it = work[-1]
            for w in it:
                if index[w] < 0:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack[w] = True
                    work.append((w, iter(succ[w])))
                    break
                if on_stack[w]:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    while True:
                        w = stack.pop()
                        on_stack[w] = False
                        label[w] = count
                        if w == v:
                            break
                    count += 1
    return label


def _gepp_stacked(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with A x = b for (k, k, n) A and (k, n) b, returned (k, n): Gaussian elimination with
    partial pivoting, each step an array operation over the n systems. Raises LinAlgError if a
    pivot is 0."""
    k, _, n = A.shape
    M = np.empty((k, k + 1, n))
    M[:, :k, :] = A
    M[:, k, :] = b
    cols = np.arange(n)
    for j in range(k):
        p = j + np.argmax(np.abs(M[j:, j, :]), axis=0)
        swap = p != j
        if swap.any():
            c = cols[swap]
            rows_p = M[p[swap], :, c]  # (s, k+1)
            rows_j = M[j, :, c]
            M[j, :, c] = rows_p
            M[p[swap], :, c] = rows_j
        piv = M[j, j]
        if not np.all(piv != 0.0):
            raise np.linalg.LinAlgError("Singular matrix")
        if j + 1 < k:
            f = M[j + 1 :, j] / piv
            M[j + 1 :, j:] -= f[:, None, :] * M[j, j:][None]
    x = np.empty((k, n))
    for j in range(k - 1, -1, -1):
        acc = M[j, k] - (M[j, j + 1 : k] * x[j + 1 :]).sum(axis=0) if j + 1 < k else M[j, k]
        x[j] = acc / M[j, j]
    return x


def solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with A x = b for every row.

    Args:
      A: (n, m, m) matrices sharing one sparsity pattern (zeros where the structure has none).
      b: (n, m) right-hand sides.
    Returns:
      (n, m) solutions, as ``numpy.linalg.solve(A, b[..., None])[..., 0]`` to round-off.
    Raises:
      numpy.linalg.LinAlgError: a system is singular.
    """
    return solve_stacked(np.ascontiguousarray(A.transpose(1, 2, 0)), np.ascontiguousarray(b.T)).T


def solve_stacked(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """As :func:`solve` with the systems stacked last: A (m, m, n), b (m, n); returns (m, n).
    The layout in which every matrix entry of all systems is one contiguous row."""
    m, _, n = A.shape
    if n == 0:
        return np.zeros((m, 0))
    pattern = np.ascontiguousarray(np.any(A != 0.0, axis=2))
    plan = _plan(pattern.tobytes(), m)
    if plan is None:
        return np.linalg.solve(A.transpose(2, 0, 1), b.T[..., None])[..., 0].T
    x = np.zeros((m, n))
    solved: set[int] = set()
    for rows, unknowns in plan:
        # Right-hand sides with the unknowns solved so far substituted, structural nonzeros only.
        rhs = np.empty((len(rows), n))
        for a, i in enumerate(rows):
            acc = b[i].copy()
            for j in np.flatnonzero(pattern[i]):
                if int(j) in solved:
                    acc -= A[i, j] * x[j]
            rhs[a] = acc
        if len(rows) == 1:
            piv = A[rows[0], unknowns[0]]
            if not np.all(piv != 0.0):
                raise np.linalg.LinAlgError("Singular matrix")
            x[unknowns[0]] = rhs[0] / piv
        else:
            blk = A[list(rows)][:, list(unknowns)]  # (k, k, n)
            if len(rows) <= MAX_BLOCK:
                x[list(unknowns)] = _gepp_stacked(blk, rhs)
            else:
                x[list(unknowns)] = np.linalg.solve(blk.transpose(2, 0, 1), rhs.T[..., None])[..., 0].T
        solved.update(unknowns)
    return x
