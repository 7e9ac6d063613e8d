"""How good a plan is: the information matrix and its numerical kernel (:mod:`.information`), the
test-pose criterion ρ0 (:mod:`.test_pose`) and the classic criteria (:mod:`.classic`)."""
