#!/usr/bin/env python3
"""Regenerate the bad-input corpus: one folder per case, each a broken copy of a shipped file
(session, URDF, companion, parameters, configs, CSV) plus `case.yaml` with the command to run and
the message it must produce. tests/bad_inputs.rs runs every case through the spmcal binary.

Run from the repository root: python3 tests/data/bad_inputs/make_corpus.py
Placeholders in `args` and `expect`: {case} = the case folder, {tmp} = a scratch folder that holds
existing outputs (existing.yaml, existing.csv, existing.rrd) that a failed run must not change, and
in which it must write nothing else.

Every expected error message holds the file (and line and column where the error has them) and the
reason, not only a path the arguments already hold: tests/bad_inputs.rs refuses an expectation
with fewer than three words beyond the arguments and the words that only locate. Line numbers are
computed from the shipped file each case breaks (line_of), so a change to that file moves them.
"""
import json
import math
import os
import shutil

ROOT = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(ROOT, "../../.."))


def read(rel):
    with open(os.path.join(REPO, rel)) as f:
        return f.read()


URDF = read("models/agile_wrist.urdf")
COMPANION = read("models/agile_wrist.yaml")
SESSION = read("datasets/agile_wrist_sim_20/session.yaml").replace("../../models", "../../../../models")
JOINTS = read("datasets/agile_wrist_sim_20/joints.csv")
MARKERS = read("datasets/agile_wrist_sim_20/markers.csv")
PARAMS = read("datasets/agile_wrist_sim_20/truth.yaml")
CALIB = read("configs/calibrate.yaml")
SIM = read("configs/simulate_agile_wrist.yaml").replace("../models", "../../../../models")

cases = []


def case(name, files, args, expect, status="error"):
    cases.append((name, files, args, expect, status))


def session(**changes):
    files = {"session.yaml": SESSION, "joints.csv": JOINTS, "markers.csv": MARKERS}
    files.update(changes)
    return files


def model(urdf=URDF, companion=COMPANION):
    return {"m.urdf": urdf, "m.yaml": companion}


def replace_once(text, old, new):
    assert old in text, old
    return text.replace(old, new, 1)


def line_of(text, needle, start=0):
    """The 1-based line of `text` on which `needle` first occurs (at or after `start`)."""
    return text[:text.index(needle, start)].count("\n") + 1


CAL = ["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--out", "{tmp}/existing.yaml", "--config", "{case}/c.yaml"]
SIMC = ["simulate", "--config", "{case}/s.yaml", "--out", "{tmp}/sim", "--poses", "30"]
FDA_MODEL = ["fda", "--joints", "datasets/joystick_circle/joints.csv", "--model", "{case}/m.urdf"]
FDA_PARAMS = ["fda", "--joints", "datasets/joystick_circle/joints.csv", "--params", "{case}/p.yaml"]

# --- YAML pathologies: bounded work, located duplicates ------------------------------------------
case("yaml_flow_nesting_bomb", {"c.yaml": "loss: " + "[" * 5000}, CAL, "c.yaml:1: nested more than 16 levels deep")
case("yaml_block_nesting", {"c.yaml": "".join(" " * d + f"k{d}:\n" for d in range(40))}, CAL, "c.yaml:17: nested more than 16 levels deep")
case("yaml_alias_bomb", {"c.yaml": "a: &a [x, x]\n" + "".join(f"b{i}: [*a, *a, *a]\n" for i in range(200))}, CAL, "c.yaml:23: more than 64 aliases")
case("yaml_two_documents", {"c.yaml": "loss: huber\n---\nloss: huber\n"}, CAL, "c.yaml:2: a second YAML document: a settings file holds one")
case("yaml_duplicate_top_key", {"c.yaml": "loss: huber\nmax_iterations: 10\nloss: least_squares\n"}, CAL, "c.yaml:3: duplicate key `loss` (first at line 1)")
case("yaml_duplicate_nested_key", {"c.yaml": "bounds:\n  axis_tilt_deg: 5\n  link_angle_deg: 5\n  axis_tilt_deg: 6\n"}, CAL, "c.yaml:4: duplicate key `bounds.axis_tilt_deg` (first at line 2)")
case("yaml_malformed", {"c.yaml": "loss: [huber\n"}, CAL, "c.yaml:2: malformed YAML: while parsing a flow sequence, expected ',' or ']'")
case("yaml_tab_indent", {"c.yaml": "bounds:\n\taxis_tilt_deg: 5\n"}, CAL, "c.yaml:2: malformed YAML: tabs disallowed within this context (block indentation)")

# --- Calibration config: every value checked where it is built, located at its key ---------------
case("calib_unknown_key", {"c.yaml": "los: huber\n"}, CAL, "c.yaml:1: unknown field `los`, expected one of `fit`")
case("calib_absurd_radius", {"c.yaml": "initial_radius_deg: 1.0e6\n"}, CAL, "c.yaml:1: column `initial_radius_deg`: `initial_radius_deg` 1000000 is absurd: a trust region of at most 90° is meaningful")
case("calib_negative_huber", {"c.yaml": "loss: huber\nhuber_threshold: -1\n"}, CAL, "c.yaml:2: column `huber_threshold`: `huber_threshold` must be a positive number (got -1)")
case("calib_nan_tolerance", {"c.yaml": "step_tolerance_deg: .nan\n"}, CAL, "c.yaml:1: column `step_tolerance_deg`: `step_tolerance_deg` must be a positive number (got NaN)")
case("calib_freeze_everything", {"c.yaml": "freeze: [actuated_axes, platform_axes, proximal_angles, distal_angles, joint_offsets]\n"}, CAL, "c.yaml:1: column `freeze`: `freeze` holds every mechanism parameter fixed: there is nothing to calibrate")
case("calib_zero_iterations", {"c.yaml": "max_iterations: 0\n"}, CAL, "c.yaml:1: column `max_iterations`: `max_iterations` must be from 1 to 10000 (got 0)")
case("calib_one_iteration", {"c.yaml": "max_iterations: 1\n"}, CAL, ["{case}/c.yaml: nominal registration: the fit did not converge within `max_iterations` = 1 iterations", "too few iterations to tell a minimum from progress): raise `max_iterations`"])
case("calib_holdout_every_pose", {"c.yaml": "holdout_every: 1\n"}, CAL, "c.yaml:1: column `holdout_every`: `holdout_every: 1` would hold out every pose")
case("calib_tolerance_above_radius", {"c.yaml": "initial_radius_deg: 1\nstep_tolerance_deg: 2\n"}, CAL, "c.yaml:2: column `step_tolerance_deg`: `step_tolerance_deg` must be smaller than `initial_radius_deg`")
case("calib_singular_ratio_above_one", {"c.yaml": "min_singular_ratio: 2\n"}, CAL, "c.yaml:1: column `min_singular_ratio`: `min_singular_ratio` must be below 1")
case("calib_negative_bound", {"c.yaml": "bounds:\n  axis_tilt_deg: -1\n"}, CAL, "c.yaml:2: column `bounds.axis_tilt_deg`: `bounds.axis_tilt_deg` must be a positive number (got -1)")
case("calib_wrong_type", {"c.yaml": "max_iterations: many\n"}, CAL, 'c.yaml:1: max_iterations: invalid type: string "many", expected u32')
case("calib_unknown_group", {"c.yaml": "freeze: [camera]\n"}, CAL, "c.yaml:1: freeze[0]: unknown variant `camera`, expected one of `actuated_axes`")
case("calib_partial_config_works", {"c.yaml": "loss: least_squares\n"}, CAL, "wrote {tmp}/existing.yaml", status="ok")

# --- Simulation config ----------------------------------------------------------------------------
case("sim_negative_sigma", {"s.yaml": replace_once(SIM, "lateral_sigma_m: 0.0002", "lateral_sigma_m: -0.0002")}, SIMC, f"s.yaml:{line_of(SIM, 'lateral_sigma_m')}: column `camera.lateral_sigma_m`: `camera.lateral_sigma_m` must be from 0 to 1 (got -0.0002)")
case("sim_tilt_over_90", {"s.yaml": replace_once(SIM, "max_tilt_deg: 30", "max_tilt_deg: 95")}, SIMC, f"s.yaml:{line_of(SIM, 'max_tilt_deg')}: column `workspace.max_tilt_deg`: `max_tilt_deg` must be below 90°")
case("sim_probability_over_one", {"s.yaml": replace_once(SIM, "outlier_probability: 0.0", "outlier_probability: 2")}, SIMC, f"s.yaml:{line_of(SIM, 'outlier_probability')}: column `camera.outlier_probability`: `outlier_probability` must lie in [0, 1]")
case("sim_zero_poses", {"s.yaml": replace_once(SIM, "poses: 400", "poses: 0")}, ["simulate", "--config", "{case}/s.yaml", "--out", "{tmp}/sim"], f"s.yaml:{line_of(SIM, 'poses: 400')}: column `poses`: `poses` (or `--poses`) must be from 1 to 1000000 (got 0)")
case("sim_gives_up", {"s.yaml": replace_once(SIM, "min_conditioning: 0.2", "min_conditioning: 0.999")}, SIMC, f"s.yaml:{line_of(SIM, 'min_conditioning:')}: column `workspace.min_conditioning`: only 0 of 30 poses survived 1600 attempts: 1600 candidates were rejected as near a singularity; loosen `workspace.min_conditioning` in the config")
case("sim_unknown_camera_key", {"s.yaml": replace_once(SIM, "  baseline_m:", "  base_line_m:")}, SIMC, f"s.yaml:{line_of(SIM, '  baseline_m:')}: camera: unknown field `base_line_m`, expected one of `height_m`")
case("sim_missing_model", {"s.yaml": replace_once(SIM, "model: agile_wrist", "model: nowhere.urdf")}, SIMC, f"s.yaml:{line_of(SIM, 'model:')}: column `model`: the model {{case}}/nowhere.urdf does not exist (the models that ship with spmcal are named agile_wrist, orbita3d)")
case("sim_unknown_shipped_name", {"s.yaml": replace_once(SIM, "model: agile_wrist", "model: agile_wrists")}, SIMC, f"s.yaml:{line_of(SIM, 'model:')}: column `model`: no model ships with spmcal under the name `agile_wrists` (the shipped models are agile_wrist, orbita3d), nor is there a file of this name")
case("sim_duplicate_key", {"s.yaml": SIM + "seed: 5\n"}, SIMC, f"s.yaml:{SIM.count(chr(10)) + 1}: duplicate key `seed` (first at line {line_of(SIM, chr(10) + 'seed:') + 1})")
case("sim_out_is_a_file", {"s.yaml": SIM}, ["simulate", "--config", "{case}/s.yaml", "--out", "{tmp}/existing.csv", "--poses", "5"], "{tmp}/existing.csv: is a file; a session is a folder")
case("sim_out_not_a_session", {"s.yaml": SIM, "notsession/readme.txt": "keep me\n"}, ["simulate", "--config", "{case}/s.yaml", "--out", "{case}/notsession", "--poses", "5"], "{case}/notsession: the folder is not empty and holds no session: refusing to write into it")
case("sim_bad_rrd_keeps_nothing", {"s.yaml": SIM}, SIMC + ["--rrd", "{tmp}/no/such/folder/r.rrd"], "{tmp}/no/such/folder/r.rrd: cannot write here: its folder {tmp}/no/such/folder does not exist")
case("sim_coincident_companion_markers", {"s.yaml": replace_once(SIM, "model: agile_wrist", "model: m.urdf"), **model(companion=replace_once(COMPANION, "m3: [0.0649519053, -0.0375, 0.06]", "m3: [-0.0649, -0.0375, 0.06]"))}, SIMC, f"m.yaml:{line_of(COMPANION, '  m3:')}: column `markers_m.m3`: markers `m2` and `m3`: markers #2 and #3 are 0.052 mm apart, within 3.0 mm (3 × the 1 mm marker noise): they coincide")

# --- URDF: what check_urdf rejects, named by joint or link -------------------------------------------
case("urdf_missing_child_link", model(replace_once(URDF, '<child link="proximal1"/>', '<child link="proximal9"/>')), FDA_MODEL, "{case}/m.urdf: joint `theta1` names child link `proximal9`, which does not exist")
case("urdf_missing_parent_link", model(replace_once(URDF, '<parent link="proximal1"/>', '<parent link="nowhere"/>')), FDA_MODEL, "{case}/m.urdf: joint `elbow1` names parent link `nowhere`, which does not exist")
case("urdf_nan_origin", model(replace_once(URDF, '<origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/>', '<origin xyz="0 nan 0" rpy="0 0 0"/><axis xyz="1 0 0"/>')), FDA_MODEL, "{case}/m.urdf: joint `elbow1` has an origin that is not finite: xyz [0.0, NaN, 0.0]")
case("urdf_inf_axis", model(replace_once(URDF, '<axis xyz="1 0 0"/>', '<axis xyz="inf 0 0"/>')), FDA_MODEL, "{case}/m.urdf: joint `elbow1` has a zero-length or non-finite axis [inf, 0.0, 0.0]")
case("urdf_zero_axis", model(replace_once(URDF, '<axis xyz="1 0 0"/>', '<axis xyz="0 0 0"/>')), FDA_MODEL, "{case}/m.urdf: joint `elbow1` has a zero-length or non-finite axis [0.0, 0.0, 0.0]")
case("urdf_duplicate_link", model(replace_once(URDF, '<link name="proximal1">', '<link name="base_link">')), FDA_MODEL, "{case}/m.urdf: link `base_link` is defined twice")
case("urdf_duplicate_joint", model(replace_once(URDF, '<joint name="elbow1"', '<joint name="theta1"')), FDA_MODEL, "{case}/m.urdf: joint `theta1` is defined twice")
case("urdf_two_parents", model(replace_once(URDF, '<parent link="proximal2"/><child link="distal2"/>', '<parent link="proximal2"/><child link="distal1"/>')), FDA_MODEL, "{case}/m.urdf: joint `elbow2` makes link `distal1` a child a second time (of joint `elbow1` too)")
case("urdf_self_loop", model(replace_once(URDF, '<parent link="proximal1"/><child link="distal1"/>', '<parent link="distal1"/><child link="distal1"/>')), FDA_MODEL, "{case}/m.urdf: joint `elbow1` has link `distal1` as both parent and child")
case("urdf_malformed_xml", model(URDF.replace("</robot>", "")), FDA_MODEL, "{case}/m.urdf: No elements found")
case("urdf_negative_shape_size", model(replace_once(URDF, '<cylinder radius="0.012"', '<cylinder radius="-0.012"')), FDA_MODEL, "{case}/m.urdf: link `proximal1` visual: has a shape size that is negative or not finite: [-0.012, ")
case("urdf_negative_mass", model(replace_once(URDF, '<link name="proximal1">', '<link name="proximal1"><inertial><mass value="-1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>')), FDA_MODEL, "{case}/m.urdf: link `proximal1` has an inertial with a negative mass or a number that is not finite")
case("urdf_missing_companion", {"m.urdf": URDF}, FDA_MODEL, "{case}/m.yaml: cannot read the URDF companion: cannot read: No such file or directory")

# --- Companion -------------------------------------------------------------------------------------
case("companion_collinear_markers", model(companion=replace_once(replace_once(COMPANION, "m1: [0.0, 0.075, 0.06]", "m1: [0.0, 0.0, 0.06]"), "m2: [-0.0649519053, -0.0375, 0.06]", "m2: [0.0, 0.0, 0.10]").replace("m3: [0.0649519053, -0.0375, 0.06]", "m3: [0.0, 0.0005, 0.14]")), FDA_MODEL, f"m.yaml:{line_of(COMPANION, 'markers_m:', COMPANION.index(chr(10) + 'markers_m:'))}: column `markers_m`: the markers cannot fix an orientation: the markers lie within 0.215 mm (RMS) of a line")
case("companion_nan_marker", model(companion=replace_once(COMPANION, "m4: [0.0, 0.0, 0.22]", "m4: [0.0, .nan, 0.22]")), FDA_MODEL, f"m.yaml:{line_of(COMPANION, '  m4:')}: column `markers_m.m4[1]`: marker `m4`'s position is not finite: component 1 is NaN")
case("companion_two_legs", model(companion=replace_once(COMPANION, "  - { actuated: theta3, intermediate: elbow3, platform: wrist3, closes_on: platform_closure3 }\n", "")), FDA_MODEL, f"m.yaml:{COMPANION[:COMPANION.index(chr(10) + 'legs:')].count(chr(10)) + 2}: column `legs`: `legs` lists 2 legs; an SPM of this kind has 3")
case("companion_duplicate_marker", model(companion=COMPANION.rstrip("\n") + "\n  m1: [0.0, 0.07, 0.06]\n"), FDA_MODEL, f"m.yaml:{COMPANION.rstrip(chr(10)).count(chr(10)) + 2}: duplicate key `markers_m.m1` (first at line {line_of(COMPANION, '  m1:')})")
case("companion_unknown_key", model(companion=COMPANION + "marker_radius_m: 0.006\n"), FDA_MODEL, f"m.yaml:{COMPANION.count(chr(10)) + 1}: unknown field `marker_radius_m`, expected one of `platform_link`")
case("companion_unknown_joint", model(companion=replace_once(COMPANION, "intermediate: elbow1", "intermediate: elbow9")), FDA_MODEL, f"m.yaml:{line_of(COMPANION, 'intermediate: elbow1')}: column `legs[0].intermediate`: joint `elbow9` is missing from {{case}}/m.urdf")

# --- Parameters file -------------------------------------------------------------------------------
leg_start = PARAMS.index("- u:")
second_leg = PARAMS.index("- u:", leg_start + 1)
case("params_two_legs", {"p.yaml": PARAMS[:leg_start] + PARAMS[second_leg:]}, FDA_PARAMS, f"p.yaml:{line_of(PARAMS, 'legs:')}: column `legs`: `legs` has 2 entries, expected 3")
case("params_non_unit_axis", {"p.yaml": PARAMS[:second_leg] + replace_once(PARAMS[second_leg:], "- u:\n  - -0.68", "- u:\n  - -1.68")}, FDA_PARAMS, f"p.yaml:{line_of(PARAMS, '- u:', second_leg)}: column `legs[1].u`: leg 2: axis u has length 1.838e0; a joint axis must be a unit vector")
case("params_link_angle_out_of_range", {"p.yaml": replace_once(PARAMS, "alpha1_deg: 90.08628802309651", "alpha1_deg: 200")}, FDA_PARAMS, f"p.yaml:{line_of(PARAMS, 'alpha1_deg:')}: column `legs[0].alpha1_deg`: leg 1: alpha1 = 200.0000° is outside (0°, 180°)")
quat_at = PARAMS.index("r_cb_wxyz:\n  - ") + len("r_cb_wxyz:\n  - ")
quat_end = PARAMS.index("\n", quat_at)
case("params_bad_quaternion", {"p.yaml": PARAMS[:quat_at] + "7.0" + PARAMS[quat_end:]}, FDA_PARAMS, f"p.yaml:{PARAMS[:quat_at].count(chr(10))}: column `camera.r_cb_wxyz`: `r_cb_wxyz` is not a unit quaternion (its norm is 7.07")
case("params_short_quaternion", {"p.yaml": PARAMS[:quat_at] + PARAMS[quat_end + 5:]}, FDA_PARAMS, f"p.yaml:{PARAMS[:quat_at].count(chr(10)) + 1}: camera.r_cb_wxyz: invalid length 3, expected an array of length 4")
case("params_wrong_format", {"p.yaml": replace_once(PARAMS, "format: spmcal-parameters/1", "format: spmcal-parameters/9")}, FDA_PARAMS, f"p.yaml:{line_of(PARAMS, 'format:')}: column `format`: format is `spmcal-parameters/9`, expected `spmcal-parameters/1`")
case("params_duplicate_key", {"p.yaml": PARAMS + "source: nominal\n"}, FDA_PARAMS, f"p.yaml:{PARAMS.count(chr(10)) + 1}: duplicate key `source` (first at line {line_of(PARAMS, 'source:')})")
# Issue 37: a parameters file finds its model by `model:` (relative to the file) and knows it by
# `model_sha256`: a model it cannot find, or one that changed, is said so, with what fixes it.
EXPORT = ["export", "--params", "{case}/p.yaml", "--urdf", "{tmp}/out.urdf"]
case("params_model_not_found", {"p.yaml": replace_once(replace_once(PARAMS, "model: agile_wrist", "model: nowhere.urdf"), "model_sha256: ", "model_sha256_was: ").replace("model_sha256_was: ", "# was: ")}, EXPORT, f"p.yaml:{line_of(PARAMS, 'model:')}: the model `{{case}}/nowhere.urdf` named by this parameters file (its `model:`) cannot be loaded")
SHA = PARAMS.split("model_sha256: ")[1][:64]
case("params_model_changed", {"p.yaml": replace_once(PARAMS, "model_sha256: " + SHA[:4], "model_sha256: 0000")}, EXPORT, f"p.yaml:{line_of(PARAMS, 'model_sha256:')}: the model `agile_wrist` this file names has changed since these parameters were made: its identity is {SHA[:12]}… where `model_sha256` says 0000")
case("params_model_sha_malformed", {"p.yaml": replace_once(PARAMS, "model_sha256: " + SHA[:4], "model_sha256: xyz4")}, EXPORT, f"p.yaml:{line_of(PARAMS, 'model_sha256:')}: column `model_sha256`: `model_sha256` is `xyz4")
case("params_nan_offset", {"p.yaml": replace_once(PARAMS, "delta_deg: 0.15425991586269458", "delta_deg: .nan")}, FDA_PARAMS, f"p.yaml:{line_of(PARAMS, 'delta_deg:')}: column `legs[0].delta_deg`: leg 1: delta is not finite")

# --- Kinematics CSV and IK -------------------------------------------------------------------------
case("fda_nan_joint", {"j.csv": "pose,theta1_rad,theta2_rad,theta3_rad\n0,0,0,0\n1,NaN,0,0\n"}, ["fda", "--joints", "{case}/j.csv"], "j.csv:3: column `theta1_rad`: `NaN` is not finite")
case("fda_ragged_row", {"j.csv": "pose,theta1_rad,theta2_rad,theta3_rad\n0,0,0\n"}, ["fda", "--joints", "{case}/j.csv"], "j.csv:2: malformed CSV: CSV error: record 1 (line: 2, byte: 38): found record with 3 fields, but the previous record has 4 fields")
case("fda_missing_column", {"j.csv": "pose,theta1_rad,theta2_rad\n0,0,0\n"}, ["fda", "--joints", "{case}/j.csv"], "j.csv:1: the header has no column `theta3_rad` (it has: pose,theta1_rad,theta2_rad)")
case("ik_non_unit_quaternion", {"o.csv": "pose,qw,qx,qy,qz\n0,1,0,0,0\n1,2,0,0,0\n"}, ["ik", "--orientations", "{case}/o.csv"], "o.csv:3: column `qw`: quaternion [2.0, 0.0, 0.0, 0.0] has norm 2.0, not 1 (within 0.001)")
case("ik_serial_singularity", {"o.csv": "pose,qw,qx,qy,qz\n0,0.816496580927726,-0.5773502691896258,0,0\n"}, ["ik", "--orientations", "{case}/o.csv"], "o.csv:2: pose 0: leg 1 is at a serial singularity: its platform axis lies")

# --- Outputs: checked before the work, written all together ------------------------------------------
CAL20 = ["calibrate", "--dataset", "datasets/agile_wrist_sim_20"]
case("out_rrd_folder_missing", {}, CAL20 + ["--out", "{tmp}/existing.yaml", "--rrd", "{tmp}/missing/r.rrd"], "{tmp}/missing/r.rrd: cannot write here: its folder {tmp}/missing does not exist")
case("out_is_a_folder", {}, CAL20 + ["--out", "{tmp}"], "{tmp}: is a folder; an output file was expected")
case("out_twice", {}, CAL20 + ["--out", "{tmp}/existing.yaml", "--rrd", "{tmp}/existing.yaml"], "{tmp}/existing.yaml: is given as two different outputs")
case("estimate_rrd_folder_missing", {}, ["estimate", "--dataset", "datasets/agile_wrist_sim_20", "--out", "{tmp}/existing.csv", "--rrd", "{tmp}/missing/e.rrd"], "{tmp}/missing/e.rrd: cannot write here: its folder {tmp}/missing does not exist")
case("ik_out_folder_missing", {}, ["ik", "--quat", "1,0,0,0", "--out", "{tmp}/missing/j.csv"], "{tmp}/missing/j.csv: cannot write here: its folder {tmp}/missing does not exist")
case("ik_out_is_a_device", {}, ["ik", "--quat", "1,0,0,0", "--out", "/dev/null"], "/dev/null: is not a regular file (a device or a pipe): outputs are written to a temporary file renamed into place, which would replace it; give a file's path")

# --- Sessions and vision ---------------------------------------------------------------------------
still = "pose,theta1_rad,theta2_rad,theta3_rad\n" + "".join(f"{p},0,0,0\n" for p in range(20))
still_markers = "pose,marker,x_m,y_m,z_m\n" + "".join(line.replace("0,", f"{p},", 1) + "\n" for p in range(20) for line in MARKERS.splitlines()[1:5])
case("session_nothing_moves", session(**{"joints.csv": still, "markers.csv": still_markers}), ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], "the MP barely moves: the largest rotation between the session's poses is 0.000°, too little to calibrate from")
ref = MARKERS.splitlines()
near = ref[:]
x, y, z = (float(v) for v in ref[1].split(",")[2:])
near[2] = f"0,m2,{x + 1e-4},{y},{z}"
case("session_reference_markers_coincide", session(**{"markers.csv": "\n".join(near) + "\n"}), ["estimate", "--dataset", "{case}"], "pose 0: markers #1 and #2 are 0.100 mm apart, within 3.0 mm (3 × the 1 mm marker noise): they coincide")
case("session_duplicate_key", session(**{"session.yaml": SESSION + "name: again\n"}), ["estimate", "--dataset", "{case}"], f"session.yaml:{SESSION.count(chr(10)) + 1}: duplicate key `name` (first at line {line_of(SESSION, 'name:')})")
case("session_nested_bomb", session(**{"session.yaml": "name: " + "{a: " * 5000}), ["estimate", "--dataset", "{case}"], "session.yaml:1: nested more than 16 levels deep")
case("session_reference_not_a_pose", session(**{"session.yaml": SESSION.replace("reference_pose: 0", "reference_pose: 99")}), ["estimate", "--dataset", "{case}"], f"session.yaml:{line_of(SESSION, 'reference_pose:')}: column `reference_pose`: reference pose 99 is not in joints.csv")


# --- Issue 33, bad inputs: linear-time YAML, refusals that name file and line, no silent accepts ---
# 100,000 nested brackets: `calibrate` reads session.yaml for the model it names before the session
# reader does (that first read was serde_yaml's, quadratic in the depth: 42 s); now both stop at
# the 17th level. tests/bad_inputs.rs times 10^5 against 2*10^5 levels of every YAML input.
case("yaml_session_100k_brackets", session(**{"session.yaml": "name: " + "[" * 100_000}), ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], "session.yaml:1: nested more than 16 levels deep")
case("yaml_companion_nested", model(companion="markers_m: " + "[" * 5000), FDA_MODEL, "m.yaml:1: nested more than 16 levels deep")
case("yaml_params_nested", {"p.yaml": "legs: " + "{a: " * 5000}, FDA_PARAMS, "p.yaml:1: nested more than 16 levels deep")
case("yaml_sim_config_nested", {"s.yaml": "camera: " + "[" * 5000}, SIMC, "s.yaml:1: nested more than 16 levels deep")
BAG_ARGS = ["calibrate", "--dataset", "{case}/rec", "--model", "models/agile_wrist.urdf", "--out", "{tmp}/p.yaml"]
case("bag_metadata_nested", {"rec/metadata.yaml": "rosbag2_bagfile_information: " + "[" * 5000}, BAG_ARGS, "rec/metadata.yaml:1: nested more than 16 levels deep")
case("bag_mapping_nested", {"rec/spmcal.yaml": "joints: " + "[" * 5000, "rec/metadata.yaml": "rosbag2_bagfile_information:\n  storage_identifier: mcap\n"}, BAG_ARGS, "rec/spmcal.yaml:1: nested more than 16 levels deep")
case("bag_metadata_duplicate_key", {"rec/metadata.yaml": "rosbag2_bagfile_information:\n  version: 5\n  version: 6\n"}, BAG_ARGS, "rec/metadata.yaml:3: duplicate key `rosbag2_bagfile_information.version` (first at line 2)")

# The reference pose's markers: the per-pose estimator's refusal names the markers.csv row (the
# second of two coincident markers, else the pose's first), never only "pose 0". The session still
# loads: the marker-level fit needs no reference pose.
case("session_reference_coincide_located", session(**{"markers.csv": "\n".join(near) + "\n"}), ["estimate", "--dataset", "{case}"], "markers.csv:3: pose 0: markers #1 and #2 are 0.100 mm apart, within 3.0 mm (3 × the 1 mm marker noise): they coincide; pose 0 is the reference pose, from which the per-pose estimator measures every pose")
line_markers = ref[:]
for k, offset in ((2, 0.05), (3, 0.10), (4, 0.15)):
    line_markers[k] = f"0,m{k},{x + offset},{y + 1e-5 * k},{z}"
case("session_reference_collinear", session(**{"markers.csv": "\n".join(line_markers) + "\n"}), ["estimate", "--dataset", "{case}"], ["markers.csv:2: pose 0: the markers lie within", "mm (RMS) of a line", "the rotation about that line is unobservable; pose 0 is the reference pose"])
two_seen = [l for l in ref if not (l.startswith("0,m3,") or l.startswith("0,m4,"))]
case("session_reference_two_markers", session(**{"markers.csv": "\n".join(two_seen) + "\n"}), ["compare", "--dataset", "{case}", "--params", "datasets/agile_wrist_sim_20/truth.yaml"], "markers.csv:2: pose 0: 2 markers seen in both this pose and the reference; at least 3 are needed; pose 0 is the reference pose")
huge = ref[:]
huge[3] = replace_once(huge[3], huge[3].split(",")[3], "1e200")
case("session_marker_coordinate_overflows", session(**{"markers.csv": "\n".join(huge) + "\n"}), ["estimate", "--dataset", "{case}"], "markers.csv:4: column `y_m`: 1e200 m is no marker position: a camera measures this mechanism's markers within 10 m")
mm = ref[:]
mm[5] = ",".join(mm[5].split(",")[:4] + ["755.9"])
case("session_marker_in_millimetres", session(**{"markers.csv": "\n".join(mm) + "\n"}), ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], "markers.csv:6: column `z_m`: 755.9 m is farther than the 10 m a camera measures this mechanism's markers within: it looks like millimetres; spmcal reads metres (755.9 mm is 0.7559 m)")
# Issue 37: a whole file in millimetres (every coordinate × 1000) is refused at its first row, not
# fitted for 200 iterations; joints in degrees at their first cell, not "near a singularity".
mm_all = [ref[0]] + [",".join(l.split(",")[:2] + [repr(round(float(v) * 1000, 6)) for v in l.split(",")[2:]]) for l in ref[1:]]
mm_col = next(j for j, v in enumerate(mm_all[1].split(",")[2:5]) if abs(float(v)) > 10)
case("session_markers_all_in_millimetres", session(**{"markers.csv": "\n".join(mm_all) + "\n"}), ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], f"markers.csv:2: column `{'xyz'[mm_col]}_m`: {mm_all[1].split(',')[2 + mm_col]} m is farther than the 10 m a camera measures this mechanism's markers within: it looks like millimetres; spmcal reads metres")
ENC_OK = "time_s,theta1_rad,theta2_rad,theta3_rad\n" + "".join(f"{t / 100},0,0,0\n" for t in range(101))
case("stream_encoders_in_degrees", {"session.yaml": SESSION, "encoders.csv": "time_s,theta1_rad,theta2_rad,theta3_rad\n0.0,0,0,0\n0.01,30,-12.5,4\n", "captures.csv": "time_s,marker,x_m,y_m,z_m\n0.005,m1,0.01,0.02,0.8\n"}, ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], "encoders.csv:3: column `theta1_rad`: 30.0 rad is more than a full turn: it looks like degrees; spmcal reads joints in radians (30.0° is 0.523599 rad)")
case("stream_captures_in_millimetres", {"session.yaml": SESSION, "encoders.csv": ENC_OK, "captures.csv": "time_s,marker,x_m,y_m,z_m\n0.5,m1,3.2,75.1,800.2\n0.5,m2,-64.9,-37.5,790.0\n"}, ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], "captures.csv:2: column `y_m`: 75.1 m is farther than the 10 m a camera measures this mechanism's markers within: it looks like millimetres; spmcal reads metres (75.1 mm is 0.0751 m)")
joint_rows = JOINTS.splitlines()
deg = [joint_rows[0]] + [",".join([l.split(",")[0]] + [repr(round(math.degrees(float(v)), 6)) for v in l.split(",")[1:4]] + l.split(",")[4:]) for l in joint_rows[1:]]
first_big = next((k, j) for k, l in enumerate(deg[1:], start=2) for j, v in enumerate(l.split(",")[1:4]) if abs(float(v)) > 2 * math.pi)
case("session_joints_in_degrees", session(**{"joints.csv": "\n".join(deg) + "\n"}), ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], f"joints.csv:{first_big[0]}: column `theta{first_big[1] + 1}_rad`: {deg[first_big[0] - 1].split(',')[first_big[1] + 1]} rad is more than a full turn: it looks like degrees; spmcal reads joints in radians")

# A station (sequential capture) that captures one marker twice and another never: refused at the
# second capture's row. (A retake, where every marker was captured too, loads with a warning:
# tests/sessions.rs.)
SEQ = "datasets/agile_wrist_sequential_200/"
SEQ_SESSION = read(SEQ + "session.yaml").replace("../../models", "../../../../models")
SEQ_MARKERS = read(SEQ + "markers.csv")
case("session_station_marker_twice_another_never", {"session.yaml": SEQ_SESSION, "joints.csv": read(SEQ + "joints.csv"), "markers.csv": replace_once(SEQ_MARKERS, "\n2,m3,", "\n2,m1,")}, ["calibrate", "--dataset", "{case}", "--out", "{tmp}/existing.yaml"], "markers.csv:4: column `marker`: station 0 captures marker `m1` twice (markers.csv lines 2 and 4, poses 0 and 2) and `m3` never: a mislabelled capture?")

# `folds`: 1 is no cross-validation (refused at its key); 0 is a choice the verdict states.
case("calib_one_fold", {"c.yaml": "folds: 1\n"}, CAL, "c.yaml:1: column `folds`: `folds: 1` is no cross-validation: one fold would hold out every pose and fit on none")
case("calib_no_folds_said", {"c.yaml": "folds: 0\n"}, CAL, ["verdict: WARN: no unseen poses were predicted (cross-validation needs `folds` of at least 2, got 0)", "wrote {tmp}/existing.yaml"], status="ok")

# A conditioning threshold that no pose can meet (the index is at most 1) is refused at its key
# before the simulator spends its attempts. (One below 1 that this model never reaches is found
# only by trying: sim_gives_up, whose message names the key to loosen.)
case("sim_conditioning_never_met", {"s.yaml": replace_once(SIM, "min_conditioning: 0.2", "min_conditioning: 1.5")}, SIMC, f"s.yaml:{line_of(SIM, 'min_conditioning:')}: column `workspace.min_conditioning`: `workspace.min_conditioning` must be below 1 (got 1.5): the conditioning index is at most 1")
# --- Issue 34: sessions seen through their cameras' pixels (pixels.csv + cameras.yaml, Kalibr's
# camchain). Every refusal names the file and line: the camchain's key (a missing key: its camera's
# line), the pixel row.
CAMERAS = """cam0:
  camera_model: pinhole
  intrinsics: [900.0, 900.0, 640.0, 400.0]
  distortion_model: radtan
  distortion_coeffs: [-0.1, 0.02, 0.001, -0.001]
  resolution: [1280, 800]
  rostopic: /cam0/image_raw
cam1:
  T_cn_cnm1:
  - [0.9987502603949663, 0.0, 0.04997916927067833, -0.12]
  - [0.0, 1.0, 0.0, 0.0]
  - [-0.04997916927067833, 0.0, 0.9987502603949663, 0.0]
  - [0.0, 0.0, 0.0, 1.0]
  camera_model: pinhole
  intrinsics: [900.0, 900.0, 640.0, 400.0]
  distortion_model: radtan
  distortion_coeffs: [-0.1, 0.02, 0.001, -0.001]
  resolution: [1280, 800]
  rostopic: /cam1/image_raw
"""
PIXELS = "pose,marker,camera,u_px,v_px\n" + "".join(
    f"{p},m{k},cam{c},{600.5 + 20 * k - 60 * c + p},{380.25 + 10 * k}\n" for p in range(20) for k in range(1, 5) for c in range(2))
CAM1 = CAMERAS.index("cam1:")


def pixel_session(**changes):
    files = {"session.yaml": SESSION, "joints.csv": JOINTS, "pixels.csv": PIXELS, "cameras.yaml": CAMERAS}
    files.update(changes)
    return files


def in_cam1(old, new):
    """CAMERAS with the first `old` of cam1's entry replaced by `new`."""
    return CAMERAS[:CAM1] + replace_once(CAMERAS[CAM1:], old, new)


EST = ["estimate", "--dataset", "{case}"]
case("pixels_camera_without_intrinsics", pixel_session(**{"cameras.yaml": in_cam1("  intrinsics: [900.0, 900.0, 640.0, 400.0]\n", "")}), EST, f"cameras.yaml:{line_of(CAMERAS, 'cam1:')}: column `cam1.intrinsics`: `cam1` has no `intrinsics` ([fu, fv, pu, pv] in pixels)")
case("pixels_camchain_not_a_rotation", pixel_session(**{"cameras.yaml": in_cam1("[0.0, 1.0, 0.0, 0.0]", "[0.0, 1.0, 0.2, 0.0]")}), EST, [f"cameras.yaml:{line_of(CAMERAS, 'T_cn_cnm1:')}: column `cam1.T_cn_cnm1`: `cam1`: the rotation of `T_cn_cnm1` is not a rotation: RᵀR departs from the identity by", "(at most 1e-6 for a rotation)"])
case("pixels_camchain_reflection", pixel_session(**{"cameras.yaml": in_cam1("[0.0, 1.0, 0.0, 0.0]", "[0.0, -1.0, 0.0, 0.0]")}), EST, f"cameras.yaml:{line_of(CAMERAS, 'T_cn_cnm1:')}: column `cam1.T_cn_cnm1`: `cam1`: the rotation of `T_cn_cnm1` is not a rotation: its determinant is -1.000000, a reflection")
case("pixels_camchain_unknown_key", pixel_session(**{"cameras.yaml": in_cam1("  rostopic:", "  frame_rate: 20\n  rostopic:")}), EST, f"cameras.yaml:{line_of(CAMERAS, 'rostopic:', CAM1)}: column `cam1.frame_rate`: unknown key `frame_rate` in `cam1`: a camera has T_cn_cnm1, camera_model")
case("pixels_camchain_bad_distortion_model", pixel_session(**{"cameras.yaml": in_cam1("distortion_model: radtan", "distortion_model: fov")}), EST, f"cameras.yaml:{line_of(CAMERAS, 'distortion_model:', CAM1)}: column `cam1.distortion_model`: `cam1`: distortion model `fov` is not one spmcal reads: `radtan`, `equidistant` or `none`")
case("pixels_camchain_gap", pixel_session(**{"cameras.yaml": CAMERAS.replace("cam1:", "cam2:")}), EST, f"cameras.yaml:{line_of(CAMERAS, 'cam1:')}: column `cam2`: `cam2` without `cam1`: the cameras are numbered cam0, cam1, … without a gap")
case("pixels_unknown_camera", pixel_session(**{"pixels.csv": replace_once(PIXELS, "\n3,m2,cam1,", "\n3,m2,cam7,")}), EST, f"pixels.csv:{line_of(PIXELS, chr(10) + '3,m2,cam1,') + 1}: column `camera`: camera `cam7` is not in cameras.yaml (cam0, cam1)")
case("pixels_seen_twice", pixel_session(**{"pixels.csv": replace_once(PIXELS, "\n1,m4,cam0,", "\n1,m4,cam1,")}), EST, f"pixels.csv:{line_of(PIXELS, chr(10) + '1,m4,cam1,') + 1}: column `camera`: marker `m4` is seen twice by camera `cam1` at pose 1")
row = line_of(PIXELS, "\n2,m3,cam0,") + 1
outside = PIXELS.splitlines()
fields = outside[row - 1].split(",")
outside[row - 1] = ",".join(fields[:3] + ["1300", fields[4]])
case("pixels_outside_the_image", pixel_session(**{"pixels.csv": "\n".join(outside) + "\n"}), EST, f"pixels.csv:{row}: column `u_px`: u = 1300.0 px is outside camera `cam0`'s image: its 1280 × 800 pixels (cameras.yaml) span u from -0.5 to 1279.5")
case("pixels_beside_markers", pixel_session(**{"markers.csv": MARKERS}), EST, "holds marker points (markers.csv) and pixels (pixels.csv): a session's observations are one or the other")
case("pixels_without_cameras_yaml", {"session.yaml": SESSION, "joints.csv": JOINTS, "pixels.csv": PIXELS}, EST, "cameras.yaml: missing: pixels.csv names the cameras of a rig, which cameras.yaml (Kalibr's camchain) defines")
case("pixels_of_a_pose_joints_lack", pixel_session(**{"pixels.csv": PIXELS + "99,m1,cam0,600,400\n"}), EST, f"pixels.csv:{PIXELS.count(chr(10)) + 1}: column `pose`: pixels for pose 99, which joints.csv does not have")
REC_PIXELS = "time_s,marker,camera,u_px,v_px\n0.5,m1,cam0,600,400\n0.5,m1,cam1,540,400\n"
case("pixels_recording_one_frame", {"session.yaml": SESSION, "encoders.csv": "time_s,theta1_rad,theta2_rad,theta3_rad\n" + "".join(f"{t / 100},0,0,0\n" for t in range(101)), "pixels.csv": REC_PIXELS, "cameras.yaml": CAMERAS}, ["replay", "--dataset", "{case}", "--rrd", "{tmp}/existing.rrd"], "pixels.csv: holds pixels in 1 camera frame: almost nothing to calibrate from")


def main():
    # Only the folders this script makes are rewritten: the hand-made cases beside them
    # (clobber_*, agree_*, model_*, limits_*, …) are kept.
    for name, *_ in cases:
        path = os.path.join(ROOT, name)
        if os.path.isdir(path):
            shutil.rmtree(path)
    for name, files, args, expect, status in cases:
        folder = os.path.join(ROOT, name)
        os.makedirs(folder)
        for rel, text in files.items():
            target = os.path.join(folder, rel)
            os.makedirs(os.path.dirname(target), exist_ok=True)
            with open(target, "w") as f:
                f.write(text)
        with open(os.path.join(folder, "case.yaml"), "w") as f:
            f.write(f"args: {json.dumps(args)}\nexpect: {json.dumps(expect)}\nstatus: {status}\n")
    print(f"{len(cases)} cases")


if __name__ == "__main__":
    main()
