"""``SparkDoor-v0``: swing a door (a revolute part) open with a floating parallel-jaw gripper."""

from __future__ import annotations

from spark_bench.envs.base import SparkArticulationEnv


class SparkDoorEnv(SparkArticulationEnv):
    """Swing a door open.

    The object is any articulated asset with a revolute (or continuous) joint (default: a seeded
    procedural cabinet), converted to MuJoCo by :mod:`spark_bench.sim`; the agent is a physically
    simulated floating parallel-jaw gripper moved by position servos on three world-aligned slide joints.
    Its wrist is a passive, spring-loaded hinge through the TCP, parallel to the door's hinge, so a held
    handle can turn between the fingers as the door swings. Control runs at 25 Hz (10 physics steps of
    4 ms). A continuous joint counts as open at pi/2.

    **Action space** ``Box(-1, 1, (4,), float32)``: ``a[0:3]`` moves the TCP target by ``0.02 * a[0:3]``
    m from the TCP's current position (world x, y, z; clipped to a workspace box around the object);
    ``a[3]`` commands the fingers: -1 fully open, +1 closed (each finger squeezes with at most 40 N).

    **Observation space** ``Box(-10, 10, (19,), float32)`` (entries clipped to the bounds; each entry is named
    in :mod:`spark_bench.envs.observation`, e.g. ``obs[GRASP]`` for 8-10):

    ====== =====================================================================
    index  meaning
    ====== =====================================================================
    0-2    TCP position (world, m)
    3      wrist angle (rad)
    4      finger opening, 0 closed to 1 fully open
    5-7    TCP velocity (m/s)
    8-10   grasp point on the door (its handle, else a finger-pull notch, else its front face
           near the free edge), world
    11-13  grasp point minus TCP
    14     joint angle as a fraction of its range (0 closed, 1 fully open)
    15     joint velocity divided by the range
    16-17  left / right finger pad contact force / 10 N, clipped to 1
    18     distance TCP to grasp point
    ====== =====================================================================

    With ``observation="frame"`` the space is ``Box(-10, 10, (37,), float32)``: the 19 entries above, then
    the grasp frame and the joint, what a policy needs to act on any asset (world frame; the directions
    turn with the part):

    ====== =====================================================================
    index  meaning
    ====== =====================================================================
    19-21  outward: out of the part's front at the grasp (the gripper approaches along its opposite)
    22-24  closing: the direction the fingers close along (across the handle)
    25-27  joint axis (unit; opening = increasing joint value)
    28-30  from the grasp point to the nearest point of the joint axis (revolute; 0 for prismatic)
    31     1 revolute or continuous, 0 prismatic
    32     1 for an inside grip (a finger-pull notch: the closed fingers enter it and open), else 0
    33     the finger command to approach with (-1 fully open; higher to fit pads beside the handle;
           +1 closed for an inside grip)
    34-36  inside grip: the direction from the notch's open edge to its inner wall (else 0)
    ====== =====================================================================

    Entries 25-31 describe the simulated asset's own joint, or ``joint_estimate=(axis, pivot, type)``
    (world frame at rest) when given: a prediction's joint, reported while acting on the real object.

    Of the part's shape a policy may read, beyond the observation, what a robot's perception would give:
    the scene's grasp (``env.unwrapped.scene.grasp``: point, outward direction, grip) and the part's surface
    at rest (:func:`~spark_bench.manipulation.scene.part_points`); the scripted opener reads the door's free edge and
    thickness from it to push a door that slipped out of the fingers open from inside
    (:func:`~spark_bench.opening.door_geometry.door_edge`).

    **End-effector** (``end_effector=``): ``"gripper"`` (the default, described above), ``"suction"`` or
    ``"auto"``. ``"suction"`` carries a 40 mm suction cup (a 32, 25 or 20 mm one where the 40 mm cup finds no
    place: :func:`~spark_bench.manipulation.suction.cup_sizes`, ``scene.gripper.config``) on the same servoed carriage
    instead of the fingers (:mod:`spark_bench.manipulation.suction`): it goes to a flat patch of the door's front face
    (as far from the hinge as the patch allows; the passive wrist lets the cup turn with the face), approaches
    along the face's normal and holds by MuJoCo's ``adhesion`` actuator, up to its rated hold (75 N for the 40
    mm cup) along the normal (more tears it off; along the face only friction holds it). ``a[3]`` is then the
    suction command (> 0: that fraction of the hold, <= 0 released); the observation keeps its size and
    layout, with entry 4 the suction command (0 to 1) and 16-17 both the cup's contact force / 10 N
    (:data:`~spark_bench.envs.observation.SUCTION`, :data:`~spark_bench.envs.observation.CUP_TOUCH`). How to
    choose: the gripper where the door has a handle, knob, notch or tab; the cup for a front with nothing to
    pinch (a flush door, lid or window); ``"auto"`` (what the opening score uses) picks per part: the cup
    where the grasp planner declines the part for lack of something to pinch (``scene.grasp.declined``
    ``no_handle``, ``too_wide`` or ``unholdable``), and where the cup opens a part whose pinch is too weak
    for it (``weak_pinch``: a heavy lid lifted by its lip moves along the fingers' closing, where one finger's
    servo holds it); the gripper everywhere else (a part declined for another
    reason keeps the gripper and its reason). The one chosen is ``env.unwrapped.end_effector`` and every
    step's ``info["end_effector"]``; the scripted opener runs the cup's own phases
    (:class:`~spark_bench.opening.suction_opener.SuctionOpener`). A part the cup cannot hold (no flat patch for the
    smallest cup, something in its way, too heavy for its hold when driven directly) gets a ``reason``, as the
    gripper's do.

    **Rewards** (``reward_type="dense"``, in [0, 1]): ``(reach + grasp + 2 progress + success) / 5`` with
    ``reach = 1 - tanh(10 d)`` (d: TCP to grasp point, m), ``grasp = 1`` when both pads touch and
    ``d < 0.03``, ``progress = min(fraction / target_fraction, 1)``, ``success = 1`` when
    ``fraction >= target_fraction``. ``reward_type="sparse"``: ``success``.

    **Starting state**: every object joint at rest (its lower limit); the TCP 0.10 m in front of the
    grasp point plus uniform noise of ±0.03 m per axis; fingers open, wrist at 0.

    **Episode end**: no termination on success (``info["is_success"]`` reports it each step); termination
    only if the physics diverges. Truncation at ``max_episode_steps`` (default 100, by
    ``gymnasium.make``'s ``TimeLimit``).

    **Arguments**: ``gymnasium.make("SparkDoor-v0", asset=None, joint=None, target_fraction=0.75,
    reward_type="dense", render_mode=None, max_episode_steps=100, seed=None,
    observation="basic", joint_estimate=None, end_effector="gripper", success_rule="spark")``; see
    :class:`~spark_bench.envs.base.SparkArticulationEnv`. A joint that does not exist, or an asset with
    no revolute joint, raises :class:`~spark_bench.errors.InputError` at ``make``.

    **Success rules** (``success_rule=``): ``"spark"`` (the default) counts the door open once it passes
    ``target_fraction`` of its range; ``"maniskill"`` (ManiSkill3's rule) also asks that the door's link be
    nearly still (the limits: :meth:`~spark_bench.envs.base.SparkArticulationEnv.evaluate`). The rule chosen
    drives ``info["is_success"]``, the ``success`` reward term and the sparse reward; every ``info`` carries
    both rules and the link's speeds.

    **Info**: ``reach``, ``grasp``, ``progress``, ``success`` (the reward terms), ``is_success`` (the chosen
    rule), ``is_success_spark``, ``is_success_maniskill``, ``link_angular_speed``, ``link_linear_speed`` and
    ``end_effector``.
    """

    joint_kind = "revolute"
