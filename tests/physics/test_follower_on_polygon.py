"""A follower pressed on a polygon (a points CSV read back): on a flat the normal stands still
while the contact runs along it, so the contact is found where the follower's line meets the
flat's offset, not at a corner."""
import numpy as np

from cadcam.physics.outline import follower_contact, outline_from_chain


def test_a_roller_on_a_hexagons_flat_sits_where_its_line_meets_the_flats_offset():
    """A hexagon of apothem h, its anchor vertex on +x and its second flat's normal at 90°,
    turned so that the normal points at a = 90° ± 20° in the world, under a roller of radius r
    riding the vertical line x = 0: the roller's centre is at s = (h + r)/sin a, the contact
    s·cos a along the flat from its middle (a side and a half, 3h·tan 30°, from the anchor),
    the pressure angle a − 90°."""
    h, r, sides = 0.02, 0.005, 6
    corner = h / np.cos(np.pi / sides)
    angles = 2 * np.pi * np.arange(sides) / sides
    hexagon = outline_from_chain(corner * np.column_stack([np.cos(angles), np.sin(angles)]), np.zeros(sides), 4,
                                 True, [])
    a = np.pi / 2 + np.radians(np.linspace(-20.0, 20.0, 9))
    psi, wrapped, s, lean = follower_contact(hexagon, a - np.pi / 2, np.pi / 2, 0.0, r)
    np.testing.assert_allclose(s, (h + r) / np.sin(a), rtol=0, atol=1e-12)
    np.testing.assert_allclose(wrapped, 3 * h * np.tan(np.pi / sides) + s * np.cos(a), rtol=0, atol=1e-12)
    np.testing.assert_allclose(lean, a - np.pi / 2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(psi, np.pi / 2, rtol=0, atol=1e-12)
