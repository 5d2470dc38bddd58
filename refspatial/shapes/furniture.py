"""Furniture that stands on a room's floor: coffee table, side table, stool, chair, cabinet.

Tops and seats are flat at the object's highest point (except the chair, whose back rises
above its seat), so the composer can set things on the pieces marked ``support`` in the
catalogue. Collision parts are the pieces' own convex blocks: legs stay legs, and the space
under a table stays open.
"""

from __future__ import annotations

import math

from . import geometry as g
from .registry import Built, register


def _legs(half_x: float, half_y: float, inset: float, side: float, height: float) -> list:
    """Four square legs from the floor to `height`, their outer faces `inset` inside the corners."""
    return [
        g.box((sx * (half_x - inset) - side / 2, sy * (half_y - inset) - side / 2, 0.0),
              (sx * (half_x - inset) + side / 2, sy * (half_y - inset) + side / 2, height))
        for sx in (-1, 1) for sy in (-1, 1)
    ]


@register("coffee_table", "length_m width_m height_m top_m leg_m", "top_m*4 <= height_m", "leg_m*4 <= width_m")
def build_coffee_table(p: dict[str, float]) -> Built:
    """Low rectangular table: a top length_m along x by width_m along y, top_m thick, its upper
    face at height_m, on four square legs leg_m across set in from the corners."""
    L, W, H, t, leg = p["length_m"], p["width_m"], p["height_m"], p["top_m"], p["leg_m"]
    top = g.rounded_slab(L / 2, W / 2, H - t, H, min(0.03, W / 8))
    legs = _legs(L / 2, W / 2, leg / 2 + 0.03, leg, H - t + 0.002)  # a hair into the top: one solid
    return g.finish(g.union([top, *legs]), [top, *legs])


@register("side_table", "radius_m height_m top_m column_radius_m", "top_m*4 <= height_m",
          "column_radius_m*3 <= radius_m")
def build_side_table(p: dict[str, float]) -> Built:
    """Round pedestal table: a disc top radius_m across, top_m thick, at height_m, on one column
    of column_radius_m standing on a round foot two thirds of the top's radius."""
    R, H, t, c = p["radius_m"], p["height_m"], p["top_m"], p["column_radius_m"]
    foot_r, foot_h = 0.66 * R, 0.025
    top = g.revolve([(0, H - t), (R - 0.006, H - t), (R, H - t + 0.006), (R, H - 0.006), (R - 0.006, H), (0, H)])
    column = g.cylinder(c, (0, 0, foot_h - 0.002), (0, 0, H - t + 0.002), 20)
    foot = g.revolve([(0, 0), (foot_r, 0), (foot_r, 0.6 * foot_h), (0.8 * foot_r, foot_h), (0, foot_h)])
    return g.finish(g.union([top, column, foot]), [top, g.hull(column.vertices), foot])


@register("stool", "radius_m height_m seat_m leg_m", "seat_m*5 <= height_m", "leg_m*5 <= radius_m")
def build_stool(p: dict[str, float]) -> Built:
    """Round stool: a cushion-thick seat radius_m across and seat_m thick at height_m, on four
    round legs leg_m in radius under the seat's rim, tied by a ring of rungs a third up."""
    R, H, s, r = p["radius_m"], p["height_m"], p["seat_m"], p["leg_m"]
    seat = g.revolve([(0, H - s), (R - 0.01, H - s), (R, H - s + 0.01), (R, H - 0.01), (R - 0.01, H), (0, H)])
    spread = 0.72 * R
    feet = [(spread * math.cos(a), spread * math.sin(a)) for a in (math.pi / 4 + k * math.pi / 2 for k in range(4))]
    legs = [g.cylinder(r, (x, y, 0.0), (x, y, H - s + 0.002), 12) for x, y in feet]
    rung_z = 0.33 * H
    rungs = [g.cylinder(0.6 * r, (*feet[k], rung_z), (*feet[(k + 1) % 4], rung_z), 10) for k in range(4)]
    return g.finish(g.union([seat, *legs, *rungs]), [seat, *(g.hull(leg.vertices) for leg in legs)])


@register("chair", "seat_width_m seat_depth_m seat_height_m back_m leg_m",
          "leg_m*6 <= seat_depth_m", "seat_height_m*0.5 <= back_m")
def build_chair(p: dict[str, float]) -> Built:
    """Dining chair facing +x: a seat seat_depth_m along x by seat_width_m along y with its top at
    seat_height_m, four legs leg_m across, and a slatted back rising back_m above the seat at -x."""
    D, W, H, B, leg = p["seat_depth_m"], p["seat_width_m"], p["seat_height_m"], p["back_m"], p["leg_m"]
    seat_t = 0.035
    seat = g.rounded_slab(D / 2, W / 2, H - seat_t, H, 0.02)
    legs = _legs(D / 2, W / 2, leg / 2 + 0.01, leg, H - seat_t + 0.002)
    x_back = -D / 2 + 0.01 + leg / 2
    posts = [g.box((x_back - leg / 2, sy * (W / 2 - 0.01 - leg / 2) - leg / 2, H - 0.002),
                   (x_back + leg / 2, sy * (W / 2 - 0.01 - leg / 2) + leg / 2, H + B)) for sy in (-1, 1)]
    rail = g.rounded_block((x_back - 0.012, -W / 2 + 0.01, H + 0.55 * B), (x_back + 0.012, W / 2 - 0.01, H + B), 0.008)
    slats = [g.box((x_back - 0.008, y - 0.015, H - 0.002), (x_back + 0.008, y + 0.015, H + 0.56 * B))
             for y in (-0.22 * W, 0.0, 0.22 * W)]
    back = g.hull_of(*posts, rail)
    return g.finish(g.union([seat, *legs, *posts, rail, *slats]), [seat, *legs, back])


@register("cabinet", "width_m depth_m height_m", "depth_m*1.2 <= width_m", "depth_m*1 <= height_m")
def build_cabinet(p: dict[str, float]) -> Built:
    """Low two-door cabinet with its doors on +x: a body depth_m along x by width_m along y,
    height_m tall, on a recessed plinth, a top overhanging by a centimetre, two door panels with
    a gap between them and a bar handle on each beside the gap."""
    D, W, H = p["depth_m"], p["width_m"], p["height_m"]
    plinth, top_t, door_t = 0.06, 0.025, 0.015
    base = g.box((-D / 2 + 0.03, -W / 2 + 0.03, 0.0), (D / 2 - 0.03, W / 2 - 0.03, plinth + 0.002))
    body = g.box((-D / 2, -W / 2, plinth), (D / 2 - door_t, W / 2, H - top_t + 0.002))
    top = g.rounded_slab(D / 2 + 0.01, W / 2 + 0.01, H - top_t, H, 0.01)
    doors, handles = [], []
    for sy in (-1, 1):
        y0, y1 = sorted((sy * 0.004, sy * (W / 2 - 0.004)))
        doors.append(g.box((D / 2 - door_t - 0.002, y0, plinth + 0.01), (D / 2, y1, H - top_t - 0.006)))
        y = sy * 0.05
        handles.append(g.cylinder(0.007, (D / 2 - 0.002, y, 0.55 * H), (D / 2 + 0.02, y, 0.55 * H), 10))
        handles.append(g.cylinder(0.006, (D / 2 + 0.02, y, 0.55 * H - 0.06), (D / 2 + 0.02, y, 0.55 * H + 0.06), 10))
    visual = g.union([base, body, top, *doors, *handles])
    shell = g.hull_of(body, top, *doors, *handles)
    return g.finish(visual, [shell, base])
