"""Thirtieth session, tuning data only: why grasp_turned_along_ridge left the failing half-cylinder grasps as
they were. Replays one challenging episode with the candidate (push_out.run_one, the same seed and palette as
its test) and prints, at each grasp on a target, the network's yaw, the crest attention's mask shows
(RuleContext.ridge), the turn onto it and whether the fingers would be clear at the turned yaw
(pose.grasp_clear_at); then each grasp's nearest target, closing angle to its axis and outcome.

    python docs/experiments_s30/ridge_clearance.py 10483 rice_husks
"""
import math
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "experiments_s14"))


def main(seed: int, palette: str) -> int:
    import push_out

    import impurity_policy.core.rules as rules
    from impurity_policy.core.pose import grasp_clear_at, turn_onto

    adjust = rules.GraspTurnedAlongRidge.adjust

    def reporting(self, ctx, pose):
        if pose.primitive == rules.GRASP and ctx.target_in_view:
            crest = ctx.ridge
            line = f"grasp at yaw {math.degrees(pose.yaw):5.1f} deg: crest "
            if crest is None:
                line += "none"
            else:
                turn = turn_onto(pose.yaw, crest, math.pi)
                clear = grasp_clear_at(ctx.obs.height, pose.heightmap_pixel, (pose.yaw + turn) % (2 * math.pi),
                                       ctx.pose_rules, ctx.grid.resolution)
                line += f"{math.degrees(crest):5.1f} deg, turn {math.degrees(turn):6.1f} deg, clear there: {clear}"
            print(line, flush=True)
        return adjust(self, ctx, pose)

    rules.GraspTurnedAlongRidge.adjust = reporting
    record = push_out.run_one(("challenging", seed, palette,
                               {"with": ["grasp_turned_along_ridge"], "grasp_geometry": True}))
    for g in record["grasps"]:
        print(f"step {g['step']:2d}: {g.get('g_shape')}, closing {g.get('g_closing')} deg from its x axis, "
              f"lifted a target: {bool(g['lifted'] and g['target'])}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(int(sys.argv[1]), sys.argv[2]))
