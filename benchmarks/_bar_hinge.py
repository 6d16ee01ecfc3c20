"""A bar-and-hinge model of a crease pattern in NumPy/SciPy: the benchmark peer of the closed-loop engine.

The model of Origami Simulator (Ghassaei, Demaine & Gershenfeld, 7OSME 2018) and MERLIN (Liu & Paulino,
Proc. R. Soc. A 473, 2017), written here from their papers: every vertex of the pattern is a point mass,
every edge and every facet diagonal is an axial spring (bar), every crease is a rotational spring on the
dihedral angle between the two triangles that share it, and every facet diagonal a stiff rotational
spring that keeps the facet flat; a dashpot beside every spring and a nodal (mass-proportional) drag
dissipate. Panels are compliant, not rigid: the closure of a loop is held by the bars' stiffness, not
exactly, so the path differs from a rigid model's; the end state does not, since a rigid folded state
(every bar at rest length, every facet flat, every crease at its target) is an exact equilibrium.
Integrated with `scipy.integrate.solve_ivp`.

Dihedral angle of an edge ``u → v`` with wing ``w1`` in the triangle that runs ``u → v`` and ``w2`` in
the one that runs ``v → u``: ``ρ = atan2(−(n1 × n2) · ê, n1 · n2)`` with ``n1 = (v − u) × (w1 − u)``,
``n2 = (u − v) × (w2 − v)``, ``ê`` the unit edge (valley positive, the FOLD convention). Its gradient
(Liu & Paulino's, in these labels): ``∂ρ/∂w_i = |e| n_i / |n_i|²``, and for the edge's ends
``∂ρ/∂u = −(1 − t1) ∂ρ/∂w1 − (1 − t2) ∂ρ/∂w2``, ``∂ρ/∂v = −t1 ∂ρ/∂w1 − t2 ∂ρ/∂w2`` with
``t_i = (w_i − u)·e/|e|²``.
"""

import dataclasses

import numpy as np
from scipy.integrate import solve_ivp

from origami_jax.fold._polygons import triangulate


@dataclasses.dataclass
class BarHinge:
    """Arrays of the model (lengths µm, masses ng, times µs, the design's units)."""

    x0: np.ndarray  # (N, 3) flat positions
    mass: np.ndarray  # (N,)
    free: np.ndarray  # (N,) bool: nodes that move (the root face's nodes are fixed)
    bars: np.ndarray  # (B, 2)
    bar_length: np.ndarray  # (B,)
    bar_stiffness: np.ndarray  # (B,) force/length
    hinges: np.ndarray  # (H, 4): u, v, w1, w2
    hinge_stiffness: np.ndarray  # (H,) torque/rad
    hinge_target: np.ndarray  # (H,) rad
    hinge_crease: np.ndarray  # (H,) crease index, −1 for a facet diagonal
    damping: float  # 1/time, mass-proportional
    viscosity: float = 0.0  # time: each spring's damper, as a multiple of its stiffness

    @property
    def n_nodes(self) -> int:
        return len(self.x0)

    def angles(self, x: np.ndarray) -> np.ndarray:
        """Dihedral fold angles of every hinge (rad, valley +) at positions `x` `(..., N, 3)`."""
        u, v, w1, w2 = (x[..., self.hinges[:, k], :] for k in range(4))
        e = v - u
        n1 = np.cross(e, w1 - u)
        n2 = np.cross(u - v, w2 - v)
        unit = e / np.linalg.norm(e, axis=-1, keepdims=True)
        return np.arctan2(-np.sum(np.cross(n1, n2) * unit, -1), np.sum(n1 * n2, -1))

    def forces(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Bar, hinge and damping forces on every node, `(N, 3)`."""
        a, b = self.bars[:, 0], self.bars[:, 1]
        d = x[b] - x[a]
        length = np.linalg.norm(d, axis=-1)
        unit_bar = d / length[:, None]
        stretch_rate = np.sum((v[b] - v[a]) * unit_bar, -1)
        tension = self.bar_stiffness * (length - self.bar_length + self.viscosity * stretch_rate)
        f_bar = tension[:, None] * unit_bar
        force = np.zeros_like(x)
        np.add.at(force, a, f_bar)
        np.add.at(force, b, -f_bar)
        u, vv, w1, w2 = (self.hinges[:, k] for k in range(4))
        e = x[vv] - x[u]
        e2 = np.sum(e * e, -1)
        n1 = np.cross(e, x[w1] - x[u])
        n2 = np.cross(x[u] - x[vv], x[w2] - x[vv])
        norm_e = np.sqrt(e2)
        unit = e / norm_e[:, None]
        rho = np.arctan2(-np.sum(np.cross(n1, n2) * unit, -1), np.sum(n1 * n2, -1))
        g1 = (norm_e / np.sum(n1 * n1, -1))[:, None] * n1
        g2 = (norm_e / np.sum(n2 * n2, -1))[:, None] * n2
        t1 = (np.sum((x[w1] - x[u]) * e, -1) / e2)[:, None]
        t2 = (np.sum((x[w2] - x[u]) * e, -1) / e2)[:, None]
        gu = -(1 - t1) * g1 - (1 - t2) * g2
        gv = -t1 * g1 - t2 * g2
        pairs = ((u, gu), (vv, gv), (w1, g1), (w2, g2))
        rate = sum(np.sum(v[nodes] * grad, -1) for nodes, grad in pairs)
        moment = (-self.hinge_stiffness * (rho - self.hinge_target + self.viscosity * rate))[
            :, None
        ]
        for nodes, grad in pairs:
            np.add.at(force, nodes, moment * grad)
        force -= self.damping * self.mass[:, None] * v
        return force

    def stiffness_matrix(self, x: np.ndarray) -> np.ndarray:
        """The stiffness matrix ``K = Σ k ∇ρ ∇ρᵀ + Σ k_bar ∇l ∇lᵀ`` at positions `x` `(N, 3)`,
        `(3N, 3N)`: the Hessian of the springs' energy at a state where every spring is at rest (the
        folded target state), where the terms in ``(ρ − ρ₀) ∇²ρ`` and ``(l − l₀) ∇²l`` vanish."""
        n = self.n_nodes
        rows = []
        a, b = self.bars[:, 0], self.bars[:, 1]
        d = x[b] - x[a]
        unit = d / np.linalg.norm(d, axis=-1, keepdims=True)
        for k, nodes, grads in ((self.bar_stiffness, (a, b), (-unit, unit)),):
            rows.append((k, nodes, grads))
        u, vv, w1, w2 = (self.hinges[:, k] for k in range(4))
        e = x[vv] - x[u]
        e2 = np.sum(e * e, -1)
        n1 = np.cross(e, x[w1] - x[u])
        n2 = np.cross(x[u] - x[vv], x[w2] - x[vv])
        g1 = (np.sqrt(e2) / np.sum(n1 * n1, -1))[:, None] * n1
        g2 = (np.sqrt(e2) / np.sum(n2 * n2, -1))[:, None] * n2
        t1 = (np.sum((x[w1] - x[u]) * e, -1) / e2)[:, None]
        t2 = (np.sum((x[w2] - x[u]) * e, -1) / e2)[:, None]
        grads = (-(1 - t1) * g1 - (1 - t2) * g2, -t1 * g1 - t2 * g2, g1, g2)
        rows.append((self.hinge_stiffness, (u, vv, w1, w2), grads))
        matrix = np.zeros((3 * n, 3 * n))
        for k, nodes, grads in rows:
            gradient = np.zeros((len(k), 3 * n))
            for node, grad in zip(nodes, grads, strict=True):
                for c in range(3):
                    np.add.at(gradient, (np.arange(len(k)), 3 * node + c), grad[:, c])
            matrix += gradient.T @ (k[:, None] * gradient)
        return matrix

    def frequencies(self, x: np.ndarray) -> np.ndarray:
        """Angular frequencies of the free nodes' small oscillations about an equilibrium `x` at which
        every spring is at rest (`stiffness_matrix`), ascending, 1/time."""
        free = np.repeat(self.free, 3)
        stiffness = self.stiffness_matrix(x)[np.ix_(free, free)]
        scale = 1 / np.sqrt(np.repeat(self.mass, 3)[free])
        eigenvalues = np.linalg.eigvalsh(scale[:, None] * stiffness * scale[None, :])
        return np.sqrt(np.clip(eigenvalues, 0.0, None))

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        del t
        n = self.n_nodes
        x = y[: 3 * n].reshape(n, 3)
        v = y[3 * n :].reshape(n, 3)
        a = self.forces(x, v) / self.mass[:, None]
        a[~self.free] = 0.0
        v = np.where(self.free[:, None], v, 0.0)
        return np.concatenate([v.ravel(), a.ravel()])

    def simulate(self, t1: float, *, n_save: int = 101, rtol: float = 1e-6, atol: float = 1e-9):
        """Fold from flat at rest: `(sol, x (t, N, 3))` (RK45: the bars are stiff enough to hold the
        loops and soft enough to keep the steps those of the folding, as Origami Simulator sets them)."""
        y0 = np.concatenate([self.x0.ravel(), np.zeros(3 * self.n_nodes)])
        ts = np.linspace(0.0, t1, n_save)
        sol = solve_ivp(self.rhs, (0.0, t1), y0, t_eval=ts, rtol=rtol, atol=atol, method="RK45")
        x = sol.y[: 3 * self.n_nodes].T.reshape(len(sol.t), self.n_nodes, 3)
        return sol, x

    def crease_angles(self, x: np.ndarray, n_creases: int) -> np.ndarray:
        """Each crease's fold angle (rad), the mean over its hinges, `(..., m)`."""
        rho = self.angles(x)
        out = np.zeros(x.shape[:-2] + (n_creases,))
        count = np.zeros(n_creases)
        for h, j in enumerate(self.hinge_crease):
            if j >= 0:
                out[..., j] += rho[..., h]
                count[j] += 1
        return out / count


def _area2(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Area of the plane triangle `a`, `b`, `c` `(2,)`."""
    return 0.5 * abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def folded_positions(pattern, system, angles: np.ndarray) -> np.ndarray:
    """Every vertex of `pattern` (µm, `(N, 3)`) in the rigid state of fold angles `angles` `(m,)`:
    each face's vertices moved with its panel (`system`'s `LoopedPanels`; body ``j`` is face
    ``geometry.tree.order[j + 1]``, the root face stays flat). For a state that closes every loop,
    faces that share a vertex put it at the same place."""
    g = pattern.geometry
    coords = np.asarray(g.frame.vertices_coords, dtype=float)
    coords = np.column_stack([coords, np.zeros(len(coords))])[:, :3] * pattern.length_scale
    tree = system.mechanism.tree
    parents = tree.parents
    points, axes = np.asarray(tree.points), np.asarray(tree.axes)
    angles = np.asarray(angles)
    # Each body's rigid motion from the flat state, composed from the base outwards (NumPy: the
    # tree's own `body_poses` would compile a program per sheet size for this one call).
    moves: dict[int, tuple[np.ndarray, np.ndarray]] = {-1: (np.eye(3), np.zeros(3))}

    def move(i: int) -> tuple[np.ndarray, np.ndarray]:
        if i not in moves:
            r_p, t_p = move(parents[i])
            w = axes[i]
            cross = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
            r = np.eye(3) + np.sin(angles[i]) * cross + (1 - np.cos(angles[i])) * cross @ cross
            moves[i] = (r_p @ r, r_p @ (points[i] - r @ points[i]) + t_p)
        return moves[i]

    order = np.asarray(g.tree.order)
    out = coords.copy()
    for body, face in enumerate(order[1:]):
        nodes = list(g.faces[face])
        rotation, translation = move(body)
        out[nodes] = coords[nodes] @ rotation.T + translation
    return out


def bar_hinge_model(
    pattern,
    system,
    *,
    bar_factor: float = 2000.0,
    facet_factor: float = 100.0,
    damping_ratio: float = 1.0,
) -> BarHinge:
    """The bar-and-hinge model of a `CreasePattern` with the hinges (stiffness, targets) and panel masses
    of `system` (its `LoopedPanels`). Bars: axial stiffness ``bar_factor · k_max / L²`` per bar (``k_max``
    the stiffest hinge), which puts the bars' frequency about ``sqrt(bar_factor)`` times above the hinges';
    facet diagonals: ``facet_factor · k_max``. The defaults are as stiff as the step release needs: with
    bars and facets ten times softer (200, 10), a 10×10 Miura-ori sheet released from flat crumples,
    folds a crease through ±π (its facets pass through each other; there is no contact) and ends
    in another state; with the defaults its facets bend up to 0.3 rad and its bars stretch up to 6 %
    on the way, and it reaches the targets (measured).

    Damping, Rayleigh's ``C = α M + β K`` written so that it acts only on the springs' own rates (a
    dashpot beside every bar and hinge, which leaves rigid motions alone): ``α = 2ζ ω_min`` and
    ``β = 2ζ / ω_max`` with ``ω_min``, ``ω_max`` the lowest and highest frequencies of the model about
    the folded target state (`BarHinge.frequencies`) and ``ζ`` = `damping_ratio`. Every mode then decays
    at least at the rate ``ζ ω_min``: with mass-proportional damping critical at the hinges' highest
    frequency instead, the sheet's slowest (collective folding) mode was overdamped five times over on
    a 5×5 sheet and still 0.075 rad from the targets after 1.5 ms."""
    g = pattern.geometry
    scale = pattern.length_scale
    key = g.frame
    coords = np.asarray(key.vertices_coords, dtype=float)
    coords = np.column_stack([coords, np.zeros(len(coords))])[:, :3] * scale
    stiffness = np.asarray(system.hinges.stiffness)
    target = np.asarray(system.hinges.target)
    mechanism = system.mechanism
    outlines = mechanism.outlines()
    masses = np.asarray(mechanism.tree.masses)
    order = np.asarray(g.tree.order)
    face_mass = np.zeros(g.n_faces)
    face_mass[order[1:]] = masses
    # The root (fixed) face gets the mass of a panel of its area, for the record; its nodes are fixed.
    del outlines
    crease_of_edge = {e: j for j, line in enumerate(g.crease_edges) for e in line}
    edges = [tuple(e) for e in np.asarray(key.edges_vertices).tolist()]
    edge_of = {frozenset(e): i for i, e in enumerate(edges)}
    triangles = []
    node_mass = np.zeros(len(coords))
    for f, face in enumerate(g.faces):
        xy = coords[list(face)] @ g.plane.T
        local = triangulate(xy)
        area = sum(_area2(xy[i], xy[j], xy[k]) for i, j, k in local)
        for i, j, k in local:
            tri = (face[i], face[j], face[k])
            triangles.append((tri, f))
            t_area = _area2(xy[i], xy[j], xy[k])
            share = face_mass[f] * t_area / area if f != g.tree.root else 0.0
            for node in tri:
                node_mass[node] += share / 3
    used = np.unique([n for tri, _ in triangles for n in tri])
    mean_mass = float(np.mean(node_mass[node_mass > 0]))
    node_mass = np.where(node_mass > 0, node_mass, mean_mass)
    # Edges of the triangles: the pattern's edges and the facet diagonals.
    sides: dict[frozenset, list[tuple[int, int, int]]] = {}
    for (a, b, c), _f in triangles:
        for u, v, w in ((a, b, c), (b, c, a), (c, a, b)):
            sides.setdefault(frozenset((u, v)), []).append((u, v, w))
    k_max = float(np.max(stiffness))
    bars, lengths, bar_k = [], [], []
    hinges, hinge_k, hinge_t, hinge_c = [], [], [], []
    for key_, runs in sides.items():
        u, v = sorted(key_)
        length = float(np.linalg.norm(coords[v] - coords[u]))
        bars.append((u, v))
        lengths.append(length)
        bar_k.append(bar_factor * k_max / length**2)
        if len(runs) != 2:
            continue
        (a1, b1, w1), (_, _, w2) = runs
        edge = edge_of.get(key_)
        crease = crease_of_edge.get(edge, -1) if edge is not None else -1
        if crease >= 0:
            line = g.crease_edges[crease]
            total = sum(
                float(np.linalg.norm(coords[edges[e][1]] - coords[edges[e][0]])) for e in line
            )
            hinge_k.append(stiffness[crease] * length / total)
            hinge_t.append(target[crease])
        else:
            hinge_k.append(facet_factor * k_max)
            hinge_t.append(0.0)
        hinges.append((a1, b1, w1, w2))
        hinge_c.append(crease)
    free = np.ones(len(coords), dtype=bool)
    free[list(g.faces[g.tree.root])] = False
    unused = np.setdiff1d(np.arange(len(coords)), used)
    free[unused] = False
    model = BarHinge(
        x0=coords,
        mass=node_mass,
        free=free,
        bars=np.asarray(bars),
        bar_length=np.asarray(lengths),
        bar_stiffness=np.asarray(bar_k),
        hinges=np.asarray(hinges),
        hinge_stiffness=np.asarray(hinge_k),
        hinge_target=np.asarray(hinge_t),
        hinge_crease=np.asarray(hinge_c),
        damping=0.0,
    )
    folded = folded_positions(pattern, system, target)
    omega = model.frequencies(folded)
    low, high = float(omega[0]), float(omega[-1])
    return dataclasses.replace(
        model, damping=2 * damping_ratio * low, viscosity=2 * damping_ratio / high
    )
