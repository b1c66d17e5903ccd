"""Pictures of a site as RGB arrays: an isometric view of the voxel grid, for ``rgb_array``.

Each cell ``(x, y, z)`` is a cube seen from above the corner ``(X, Y)``: three faces (top,
left, right) shaded differently. The ground, the foundations and the obstacles are drawn once
per site into a background with a depth map; each frame draws the components (coloured by
state in each kind's colours, as in the 3D replays), free targets as faint ghosts, closed
zones in red on the ground and one mast per crane (yellow at work, grey idle, red when broken
down) over it, in back-to-front order, hidden where the background stands in front. numpy only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from multicrane.core.kinds import kind_spec

if TYPE_CHECKING:
    from multicrane.sim.simulator import Simulator

BACKGROUND = (250, 250, 247)
GROUND = (214, 214, 208)
CONSTRUCTION_AREA = (196, 200, 214)
FOUNDATION = (120, 120, 120)
OBSTACLE = (90, 90, 95)
CLOSED = (230, 60, 50)
CRANE_WORKING = (250, 200, 30)
CRANE_IDLE = (150, 150, 150)
CRANE_DOWN = (220, 40, 40)
GHOST = (40, 40, 40)
GHOST_ALPHA = 0.25  # how strongly a free target shows over what is behind it
SHADES = (1.0, 0.78, 0.6)  # top, left and right faces
TARGET_WIDTH = 560  # the image's width in pixels, about (a cell is at least 4 pixels wide)


def _face_masks(a: int) -> np.ndarray:
    """(3, 2a, 2a) bool: the top, left and right faces of a cube whose top face's back corner
    is at pixel (a, 0) of the sprite (x grows right and down, y left and down, z up)."""
    py, px = np.mgrid[0 : 2 * a, 0 : 2 * a].astype(float) + 0.5
    half = a / 2
    top = np.abs(px - a) / a + np.abs(py - half) / half <= 1.0
    left = (px <= a) & (py >= half + px / 2) & (py <= half + a + px / 2) & ~top
    right = (px > a) & (py >= a - (px - a) / 2) & (py <= 2 * a - (px - a) / 2) & ~top
    return np.stack([top, left, right])


class SiteImage:
    """Draws one scenario's site; ``draw(sim)`` returns a fresh (H, W, 3) uint8 array."""

    def __init__(self, sim: Simulator, width: int = TARGET_WIDTH):
        X, Y, H = sim.scenario.size
        self.size = (X, Y, H)
        a = max(4, (width // (X + Y)) // 2 * 2)  # even, so that half a cell is whole pixels
        self.a = a
        self.shape = ((X + Y) * a // 2 + H * a + a, (X + Y) * a + a)
        self.origin = (Y * a, H * a)  # pixel (column, row) of the point (0, 0, 0)
        masks = _face_masks(a)
        face, dy, dx = np.nonzero(masks)
        self.face, self.offsets = face, dy * self.shape[1] + dx  # per sprite pixel
        self.face_pixels = [np.flatnonzero(face == f) for f in range(3)]
        spec_colors = [kind_spec(int(c.kind)).colors for c in sim.scenario.components]
        rgbs = [GROUND, CONSTRUCTION_AREA, FOUNDATION, OBSTACLE, CLOSED, GHOST]
        rgbs += [CRANE_WORKING, CRANE_IDLE, CRANE_DOWN]
        self.base_color = {rgb: i for i, rgb in enumerate(rgbs)}
        palette_of = {}
        for colors in spec_colors:
            for rgba in colors:
                palette_of.setdefault(tuple(rgba[:3]), len(rgbs) + len(palette_of))
        rgbs += list(palette_of)
        shades = np.array(SHADES)[None, :, None]
        self.palette = np.round(np.array(rgbs, dtype=float)[:, None, :] * shades).astype(np.uint8)
        self.palette_rows = self.palette.reshape(-1, 3)  # row 3 * colour + face
        ghost = self.palette[self.base_color[GHOST]].astype(np.uint16)
        self._ghost_rgb = ghost * (256 - _KEEP)  # per face, in 1/256ths
        # the palette entry of each (component, status)
        self.component_color = np.array(
            [[palette_of[tuple(rgba[:3])] for rgba in colors] for colors in spec_colors],
            dtype=np.intp,
        ).reshape(len(spec_colors), -1)
        self.bases = [crane.base for crane in sim.scenario.crane_specs or ()]
        self._ghost_cache = None
        self._nearest = np.empty(self.shape[0] * self.shape[1], dtype=np.int32)  # scratch
        self.background, self.depth = self._background(sim)

    def keys(self, x, y, z):
        """Back-to-front order: a larger key is nearer the viewer."""
        return (x + y) * (self.size[2] + 2) + z

    def _pixels(self, x, y, z, faces) -> tuple[np.ndarray, np.ndarray]:
        """Flat pixel indices and face numbers of the cubes of cells (x, y, z) (arrays),
        only the faces given by ``faces`` ((N, 3) bool: top, left, right)."""
        a = self.a
        row = self.origin[1] + (x + y) * a // 2 - z * a
        col = self.origin[0] + (x - y) * a - a
        start = row * self.shape[1] + col
        pix = start[:, None] + self.offsets[None, :]
        keep = faces[:, self.face]
        return pix[keep], np.broadcast_to(self.face, pix.shape)[keep]

    def _paint(self, img, depth, x, y, z, color, faces) -> tuple[np.ndarray, np.ndarray]:
        """Opaque cubes in front of what ``depth`` holds, the nearest at each pixel; returns
        the pixels painted and their keys."""
        pix, face, key, col = self._front(depth, x, y, z, color, faces)
        img.reshape(-1)[_channels(pix)] = np.take(self.palette_rows, 3 * col + face, axis=0)
        depth[pix] = key
        return pix, key

    def _front(self, depth, x, y, z, color, faces):
        """The pixels of these cubes in front of ``depth``: per pixel the nearest cube's pixel
        index, face, key and palette colour."""
        pix, face = self._pixels(x, y, z, faces)
        per_cube = faces[:, self.face].sum(axis=1)
        key = np.repeat(self.keys(x, y, z).astype(np.int32), per_cube)
        behind = depth[pix]
        nearest = self._nearest  # per pixel: the largest key, of ``depth`` and these cubes
        nearest[pix] = behind
        np.maximum.at(nearest, pix, key)
        # Two cubes with one key never share a pixel (same x + y and z: 2a pixels apart),
        # so each pixel has at most one winner.
        won = (key == nearest[pix]) & (key > behind)
        return pix[won], face[won], key[won], np.repeat(color, per_cube)[won]

    # -- the two layers ---------------------------------------------------------------------

    def _background(self, sim: Simulator) -> tuple[np.ndarray, np.ndarray]:
        img = np.empty((self.shape[0] * self.shape[1], 3), dtype=np.uint8)
        img[:] = BACKGROUND
        depth = np.full(len(img), -(2**30), dtype=np.int32)
        X, Y, _ = self.size
        scenario = sim.scenario
        x, y = (v.ravel() for v in np.mgrid[0:X, 0:Y])
        color = np.full(len(x), self.base_color[GROUND])
        in_area = scenario.in_construction_area
        inside = np.array([in_area(int(i), int(j)) for i, j in zip(x, y, strict=True)])
        color[inside] = self.base_color[CONSTRUCTION_AREA]
        for fx, fy in scenario.foundations:
            color[fx * Y + fy] = self.base_color[FOUNDATION]
        tops = np.zeros((len(x), 3), dtype=bool)
        tops[:, 0] = True
        self._paint(img, depth, x, y, np.zeros_like(x), color, tops)
        depth[:] = -(2**30)  # the ground hides nothing
        cells = np.array(sorted(scenario.obstacle_cells()), dtype=np.int64).reshape(-1, 3)
        solid = np.zeros((X + 2, Y + 2, self.size[2] + 2), dtype=bool)
        solid[cells[:, 0] + 1, cells[:, 1] + 1, cells[:, 2]] = True
        self._paint(img, depth, *cells.T, np.full(len(cells), self.base_color[OBSTACLE]),
                    _visible_faces(solid, cells))
        return img, depth

    def draw(self, sim: Simulator) -> np.ndarray:
        """The site now: components, free targets, closed zones and cranes."""
        veiled, ghost_key, ghost_face = self._ghosts(sim)
        img = veiled.copy()
        depth = self.depth.copy()
        X, Y, H = self.size
        occ = sim.state.occ.reshape(sim.site.shape)
        inner = occ[1 : X + 1, 1 : Y + 1, 1 : H + 1]
        closed = getattr(sim, "closed", None)
        if closed is not None and closed.any():
            columns = closed.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, 1 : H + 1].any(axis=2)
            x, y = np.nonzero(columns)
            tops = np.zeros((len(x), 3), dtype=bool)
            tops[:, 0] = True
            pix, face, _, col = self._front(depth, x, y, np.zeros_like(x),
                                            np.full(len(x), self.base_color[CLOSED]), tops)
            img[pix] = (0.6 * self.palette[col, face] + 0.4 * self.background[pix]).astype(np.uint8)
            self._veil(img, pix[ghost_key[pix] > depth[pix]], ghost_face)
        x, y, z = np.nonzero(inner > 0)
        comp = inner[x, y, z].astype(np.intp) - 1
        color = self.component_color[comp, sim.state.status[comp].astype(np.intp)]
        mx, my, mz, mcolor = self._masts(sim, occ)
        x, y, z = np.concatenate([x, mx]), np.concatenate([y, my]), np.concatenate([z + 1, mz])
        color = np.concatenate([color, mcolor])
        cells = np.stack([x, y, z], axis=1)
        solid = np.zeros(occ.shape, dtype=bool)  # the padding hides no face
        solid[1 : X + 1, 1 : Y + 1, 1 : H + 1] = inner != 0
        solid[mx + 1, my + 1, mz] = True
        pix, key = self._paint(img, depth, x, y, z, color, _visible_faces(solid, cells))
        self._veil(img, pix[ghost_key[pix] > key], ghost_face)
        return img.reshape(*self.shape, 3)

    def _veil(self, img: np.ndarray, pix: np.ndarray, ghost_face: np.ndarray) -> None:
        """Blend the ghosts' faces (``ghost_face``, per pixel) over ``img`` at ``pix``."""
        flat, at = img.reshape(-1), _channels(pix)
        rgb = np.take(self._ghost_rgb, ghost_face[pix], axis=0)
        flat[at] = ((flat[at].astype(np.uint16) * _KEEP + rgb) >> 8).astype(np.uint8)

    def _ghosts(self, sim: Simulator):
        """The free targets' cubes, kept until a target fills or frees: the background with
        them blended in, and per pixel the nearest ghost's key (``-2**30`` where none) and
        face. A frame blends them again only over what it paints behind them (a component
        passing through a target cell hides its ghost by the depth test)."""
        filled = sim.state.filled_by.tobytes()
        if self._ghost_cache is not None and self._ghost_cache[0] == filled:
            return self._ghost_cache[1]
        X, Y, H = self.size
        target_at = sim.site.target_at.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, 1 : H + 1]
        x, y, z = np.nonzero(target_at >= 0)
        free = sim.state.filled_by[target_at[x, y, z]] < 0
        x, y, z = x[free], y[free], z[free] + 1
        faces = np.ones((len(x), 3), dtype=bool)
        color = np.full(len(x), self.base_color[GHOST])
        ghost_key = np.full(self.shape[0] * self.shape[1], -(2**30), dtype=np.int32)
        pix, face, key, _ = self._front(ghost_key, x, y, z, color, faces)
        ghost_key[pix] = key
        ghost_face = np.zeros(len(ghost_key), dtype=np.intp)
        ghost_face[pix] = face
        veiled = self.background.copy()
        self._veil(veiled, pix[key > self.depth[pix]], ghost_face)
        found = (veiled, ghost_key, ghost_face)
        self._ghost_cache = (filled, found)
        return found

    def _masts(self, sim: Simulator, occ: np.ndarray):
        cells, colors = [], []
        for k, (bx, by) in enumerate(self.bases[: sim.n_cranes]):
            if not sim.crane_up(k):
                rgb = CRANE_DOWN
            elif sim.state.held[k] >= 0 or sim.state.assembling[k]:
                rgb = CRANE_WORKING
            else:
                rgb = CRANE_IDLE
            for z in range(1, self.size[2] + 1):
                if occ[bx + 1, by + 1, z] == 0:
                    cells.append((bx, by, z))
                    colors.append(self.base_color[rgb])
        arr = np.array(cells, dtype=np.int64).reshape(-1, 3)
        return arr[:, 0], arr[:, 1], arr[:, 2], np.array(colors, dtype=np.intp)


def _channels(pix: np.ndarray) -> np.ndarray:
    """(N, 3) indices into the flat (H * W * 3) image of the red, green and blue bytes of the
    pixels ``pix``: numpy gathers and scatters a flat array several times faster than rows."""
    return 3 * pix[:, None] + _RGB


def _visible_faces(solid: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(N, 3) bool: whether each cube's top, left (+y) and right (+x) face is uncovered;
    ``solid`` is the padded grid (index x + 1, y + 1, z), ``cells`` (N, 3) unpadded (x, y, z)."""
    px, py, pz = cells[:, 0] + 1, cells[:, 1] + 1, cells[:, 2]
    return np.stack(
        [~solid[px, py, pz + 1], ~solid[px, py + 1, pz], ~solid[px + 1, py, pz]], axis=1
    )


_RGB = np.arange(3)
_KEEP = round((1 - GHOST_ALPHA) * 256)  # a ghost's blend, in 1/256ths of what is behind it

__all__ = ["SiteImage"]
