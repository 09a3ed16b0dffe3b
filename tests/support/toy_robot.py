"""Small robot descriptions written by the robots init/check tests: a 6-joint arm with a two-finger
gripper on a box base, as plain URDF and as xacro (a macro and a property)."""

from __future__ import annotations

#: Joint axes of the six arm joints (z, y, y, x, y, x: a spherical-ish wrist).
AXES = ("0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0")
#: Offsets of the arm joints from their parent link [m].
OFFSETS = ("0 0 0.5", "0 0 0.1", "0.3 0 0", "0.3 0 0", "0.05 0 0", "0.05 0 0")


def _link(name: str, box: str | None = None) -> str:
    if box is None:
        return f'<link name="{name}"/>'
    return f'<link name="{name}"><collision><geometry><box size="{box}"/></geometry></collision></link>'


def arm_urdf(name: str = "toy", joints: int = 6, mount: float = 0.5) -> str:
    """URDF text: base_footprint -> base_link (0.6 x 0.5 m box) -> ``joints`` revolute joints (the first
    ``mount`` [m] above the base link's centre) ->
    gripper_tool_frame and two prismatic finger joints (the right one a mimic) along +x."""
    parts = [
        f'<robot name="{name}">',
        _link("base_footprint"),
        _link("base_link", "0.6 0.5 0.3"),
        '<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>'
        '<origin xyz="0 0 0.15"/></joint>',
    ]
    parent = "base_link"
    for i in range(joints):
        parts.append(_link(f"link_{i + 1}"))
        parts.append(
            f'<joint name="joint_{i + 1}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link_{i + 1}"/><origin xyz="{f"0 0 {mount}" if i == 0 else OFFSETS[i % 6]}"/><axis xyz="{AXES[i % 6]}"/>'
            '<limit lower="-2" upper="2" effort="10" velocity="1"/></joint>'
        )
        parent = f"link_{i + 1}"
    parts += [
        _link("gripper_tool_frame"),
        f'<joint name="tool_joint" type="fixed"><parent link="{parent}"/><child link="gripper_tool_frame"/>'
        '<origin xyz="0.12 0 0"/></joint>',
    ]
    for side, y, mimic in (("left", 0.03, ""), ("right", -0.03, '<mimic joint="finger_left_joint"/>')):
        parts += [
            _link(f"finger_{side}_link"),
            f'<joint name="finger_{side}_joint" type="prismatic"><parent link="{parent}"/>'
            f'<child link="finger_{side}_link"/><origin xyz="0.1 {y} 0"/><axis xyz="0 1 0"/>'
            f'<limit lower="0" upper="0.04" effort="1" velocity="1"/>{mimic}</joint>',
        ]
    parts.append("</robot>")
    return "\n".join(parts)


def arm_xacro() -> str:
    """The same kind of robot written with a xacro property (the link length) and a macro (a joint)."""
    joints = "\n".join(
        f'<xacro:arm_joint n="{i + 1}" parent="{"base_link" if i == 0 else f"link_{i}"}" xyz="{OFFSETS[i]}" '
        f'axis="{AXES[i]}"/>'
        for i in range(6)
    )
    return f"""<?xml version="1.0"?>
<robot name="xtoy" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="limit" value="2.0"/>
  <xacro:macro name="arm_joint" params="n parent xyz axis">
    <link name="link_${{n}}"/>
    <joint name="joint_${{n}}" type="revolute">
      <parent link="${{parent}}"/><child link="link_${{n}}"/>
      <origin xyz="${{xyz}}"/><axis xyz="${{axis}}"/>
      <limit lower="${{-limit}}" upper="${{limit}}" effort="10" velocity="1"/>
    </joint>
  </xacro:macro>
  <link name="base_footprint"/>
  <link name="base_link"><collision><geometry><box size="0.6 0.5 0.3"/></geometry></collision></link>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>
    <origin xyz="0 0 0.15"/></joint>
  {joints}
  <link name="gripper_tool_frame"/>
  <joint name="tool_joint" type="fixed"><parent link="link_6"/><child link="gripper_tool_frame"/>
    <origin xyz="0.12 0 0"/></joint>
  <link name="finger_left_link"/>
  <joint name="finger_left_joint" type="prismatic"><parent link="link_6"/><child link="finger_left_link"/>
    <origin xyz="0.1 0.03 0"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <link name="finger_right_link"/>
  <joint name="finger_right_joint" type="prismatic"><parent link="link_6"/><child link="finger_right_link"/>
    <origin xyz="0.1 -0.03 0"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/>
    <mimic joint="finger_left_joint"/></joint>
</robot>
"""
