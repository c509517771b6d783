"""URDF text for spmcal's model generators (generate_agile_wrist.py, generate_orbita3d.py):
vector helpers, chord-cylinder collision arcs, links and revolute joints whose origins are all
at the centre of rotation O (so each joint axis is its axis in B at the zero configuration).
"""
import math


def add(a, b): return [x + y for x, y in zip(a, b)]
def sub(a, b): return [x - y for x, y in zip(a, b)]
def mul(a, s): return [x * s for x in a]
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def norm(a): return math.sqrt(dot(a, a))
def unit(a): return mul(a, 1.0 / norm(a))


def rpy_aligning_z(d):
    """Roll-pitch-yaw whose rotation maps the local z axis onto unit vector d."""
    d = unit(d)
    pitch = math.atan2(math.hypot(d[0], d[1]), d[2])
    yaw = math.atan2(d[1], d[0])
    # R = Rz(yaw) Ry(pitch): z -> (sin p cos y, sin p sin y, cos p)
    return 0.0, pitch, yaw


class Urdf:
    """Writes URDF elements with numbers formatted by `number` (a float -> str function)."""

    def __init__(self, number, link_radius):
        self.f = number
        self.link_radius = link_radius

    def fv(self, a):
        return " ".join(self.f(x) for x in a)

    def cylinder(self, a, b, radius):
        mid, d = mul(add(a, b), 0.5), sub(b, a)
        geo = f'<cylinder radius="{self.f(radius)}" length="{self.f(norm(d))}"/>'
        origin = f'<origin xyz="{self.fv(mid)}" rpy="{self.fv(rpy_aligning_z(d))}"/>'
        return (f"    <visual>{origin}<geometry>{geo}</geometry></visual>\n"
                f"    <collision>{origin}<geometry>{geo}</geometry></collision>\n")

    def arc(self, a, b, radius, segments=3):
        """Chord cylinders (of the link radius) along the great-circle arc from direction a to b."""
        a, b = unit(a), unit(b)
        n = unit(sub(b, mul(a, dot(a, b))))
        ang = math.acos(max(-1, min(1, dot(a, b))))
        pts = [mul(add(mul(a, math.cos(ang * k / segments)), mul(n, math.sin(ang * k / segments))), radius)
               for k in range(segments + 1)]
        return "".join(self.cylinder(pts[k], pts[k + 1], self.link_radius) for k in range(segments))

    @staticmethod
    def link(name, body=""):
        return f'  <link name="{name}">\n{body}  </link>\n'

    def joint(self, name, parent, child, axis):
        limit = '<limit lower="-3.14159" upper="3.14159" effort="5" velocity="10"/>'
        return (f'  <joint name="{name}" type="revolute">\n'
                f'    <parent link="{parent}"/><child link="{child}"/>\n'
                f'    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="{self.fv(axis)}"/>{limit}\n'
                f'  </joint>\n')
