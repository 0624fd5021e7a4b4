"""Point-cloud perception with Open3D: register the pegboard, locate the blocks, choose grasps.

`board.PegboardRegistration.fit(cloud)` refines the camera's extrinsics once per trial and finds the
pegs; `blocks.locate_blocks(cloud, board)` segments and registers every block; `grasp.select_grasp`
picks the paper's grasp for an arm. Failures are reported (`ok`, `reason`), never guessed.
"""
