"""The oracle: a privileged policy that solves tasks from the simulator's true state with a motion planner; its
only job is to prove tasks solvable. Its layers, each importing only those listed before it:

- `geometry`: pose and box arithmetic;
- `gripper`: the hand's geometry (open fingers' gap from the robot model, pads, the hand's solids);
- `world`: a read-only view of the scene (object points, footprints, mass, supports, containers, fixtures,
  ray-cast grids of what is around);
- `scoring`: the named terms grasp candidates are ranked by;
- `grasps`: top-down grasp generators and the one rule that picks among them (`grasp_pose`);
- `side_grasps`: grasps with the hand not pointing down (a lying container's rim, under a shelf level, a
  handle out of a bin);
- `clearance`: heights over the scene for approaches and carries;
- `places`: where a held object is set down (free spots in, on, next to and off things);
- `motion`: the motion planner (inverse kinematics, straight and joint-space moves, collision checks, the
  action queue);
- `skills`: pick-and-place, picking off a shelf, a side hold, standing a lying object up;
- `compile`: the task's success condition -> jobs;
- `policy`: `OraclePolicy`, the closed loop over the jobs.
"""

from robolab_ms.policies.oracle.compile import SOLVABLE_PREDICATES, Job, job_done, jobs_for, spare_jobs
from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.policy import OraclePolicy

__all__ = ["SOLVABLE_PREDICATES", "Job", "OracleFailure", "OraclePolicy", "job_done", "jobs_for", "spare_jobs"]
