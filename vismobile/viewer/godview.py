"""The god view: the world seen from above (or the side) with the camera's frustum, the
partition nodes drawn this frame and the triangles sent (and culled) marked on it.

Drawn with numpy and Pillow into an (H, W, 3) uint8 image. The world's outline (every triangle
edge, grey) is drawn once per view; per frame only the sent (or culled) triangles' centroids,
the drawn nodes' boxes and the frustum are added.
"""
from __future__ import annotations

import numpy as np

# view -> (horizontal axis, vertical axis, vertical axis grows up the image)
VIEWS = {"top": (0, 2, False), "side": (0, 1, True)}
# The outline leaves out triangles facing the viewer (floors from the top, end walls from the
# side): they would fill the picture; walls seen edge-on draw the floor plan.
FACING = 0.7
BACKGROUND = (24, 26, 32)
OUTLINE = (90, 94, 104)
SENT = (80, 220, 120)
CULLED = (230, 60, 60)
NODES = (240, 200, 40)
FRUSTUM = (255, 255, 255)
LEVEL = (120, 200, 255)  # an object's level of detail, when coarser than full (0)


class GodView:
    """Top or side projection of one world into a (height, width) image."""

    def __init__(self, world, size=(360, 360), margin=0.05):
        self.world = world
        self.width, self.height = (int(v) for v in size)
        low, high = np.asarray(world.extent, dtype=np.float64)
        pad = margin * max(float((high - low).max()), 1e-9)
        self.low, self.high = low - pad, high + pad
        self._outline = {}

    def to_pixels(self, points, view) -> np.ndarray:
        """(N, 2) float64 pixel (column, row) of (N, 3) world points in a view, aspect kept."""
        h, v, up = VIEWS[view]
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        span = self.high - self.low
        scale = min(self.width / span[h], self.height / span[v])
        off_x = (self.width - span[h] * scale) / 2.0
        off_y = (self.height - span[v] * scale) / 2.0
        x = (points[:, h] - self.low[h]) * scale + off_x
        y = (points[:, v] - self.low[v]) * scale + off_y
        if up:
            y = self.height - 1 - y
        return np.column_stack([x, y])

    def outline(self, view) -> np.ndarray:
        """(H, W, 3) uint8 background: the edges of every triangle not facing the viewer,
        drawn once per view."""
        if view not in self._outline:
            image = np.empty((self.height, self.width, 3), dtype=np.uint8)
            image[:] = BACKGROUND
            h, v, _ = VIEWS[view]
            depth_axis = 3 - h - v
            edge_on = np.abs(self.world.normals[:, depth_axis]) < FACING
            corners = self.world.corners[edge_on].reshape(-1, 3)
            pixels = self.to_pixels(corners, view).reshape(-1, 3, 2)
            starts = pixels.reshape(-1, 2)
            ends = np.roll(pixels, -1, axis=1).reshape(-1, 2)
            self._splat(image, starts, ends, OUTLINE)
            self._outline[view] = image
        return self._outline[view]

    def _splat(self, image, starts, ends, colour) -> None:
        """Mark pixels along each segment (one sample per pixel of its longer side)."""
        steps = np.ceil(np.abs(ends - starts).max(axis=1)).astype(np.int64)
        steps = np.minimum(steps, max(self.width, self.height)) + 1
        owner = np.repeat(np.arange(len(steps)), steps)
        first = np.cumsum(steps) - steps
        t = (np.arange(len(owner)) - first[owner]) / np.maximum(steps[owner] - 1, 1)
        points = starts[owner] + (ends[owner] - starts[owner]) * t[:, None]
        self._dots(image, points, colour)

    def _dots(self, image, pixels, colour) -> None:
        ij = np.rint(pixels).astype(np.int64)
        inside = ((ij[:, 0] >= 0) & (ij[:, 0] < self.width) & (ij[:, 1] >= 0)
                  & (ij[:, 1] < self.height))
        image[ij[inside, 1], ij[inside, 0]] = colour

    def draw(self, view, camera, sent, node_boxes=None, culled=None,
             levels=None) -> np.ndarray:
        """(H, W, 3) uint8 god view of one frame.

        sent       : (S,) int64 triangle ids sent this frame (their centroids in green)
        node_boxes : (D, 2, 3) float64 boxes of the drawn partition nodes (yellow outlines)
        culled     : (C,) int64 triangle ids culled this frame (red), or None to leave them out
        levels     : (objects (k,), levels (k,), boxes (k, 2, 3)) with level of detail: each
                     object drawn coarser than full detail gets its level number at its box
        """
        from PIL import Image, ImageDraw

        image = self.outline(view).copy()
        if culled is not None and len(culled):
            self._dots(image, self.to_pixels(self.world.centroids[culled], view), CULLED)
        if len(sent):
            self._dots(image, self.to_pixels(self.world.centroids[sent], view), SENT)
        picture = Image.fromarray(image)
        draw = ImageDraw.Draw(picture)
        if node_boxes is not None and len(node_boxes):
            boxes = np.asarray(node_boxes, dtype=np.float64)
            low = self.to_pixels(boxes[:, 0], view)
            high = self.to_pixels(boxes[:, 1], view)
            corner_a, corner_b = np.minimum(low, high), np.maximum(low, high)
            for a, b in zip(corner_a.tolist(), corner_b.tolist()):  # drawn nodes, not the world
                draw.rectangle([a[0], a[1], b[0], b[1]], outline=NODES)
        if levels is not None:
            objects, numbers, boxes = levels
            coarse = np.flatnonzero(np.asarray(numbers) > 0)
            if len(coarse):
                centres = self.to_pixels(np.asarray(boxes)[coarse].mean(axis=1), view)
                for (x, y), number in zip(centres.tolist(), np.asarray(numbers)[coarse]):
                    draw.text((x + 2, y - 5), str(int(number)), fill=LEVEL)
        self._frustum(draw, view, camera)
        return np.asarray(picture)

    def _frustum(self, draw, view, camera) -> None:
        """The eye and the four side edges of the frustum, cut at the world's size or far."""
        right, up, forward = camera.basis()
        reach = min(camera.far, float((self.high - self.low).max()) * 1.5)
        tan_v = np.tan(np.radians(camera.fov) / 2.0)
        tan_h = tan_v * camera.aspect
        signs = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], dtype=np.float64)
        directions = (forward + signs[:, :1] * tan_h * right + signs[:, 1:] * tan_v * up)
        far = camera.eye + reach * directions
        eye = self.to_pixels(camera.eye, view)[0]
        ends = self.to_pixels(far, view)
        for end in ends.tolist():
            draw.line([tuple(eye), tuple(end)], fill=FRUSTUM)
        draw.line([tuple(p) for p in ends.tolist()] + [tuple(ends[0])], fill=FRUSTUM)
        draw.ellipse([eye[0] - 3, eye[1] - 3, eye[0] + 3, eye[1] + 3], fill=CULLED)
