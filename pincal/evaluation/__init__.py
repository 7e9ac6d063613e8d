"""How good a plan is: the information matrix and its numerical kernel (:mod:`.information`), the
criterion interface (:mod:`.criterion`) and one module per criterion — the test-pose criterion ρ0
(:mod:`.test_pose`, :mod:`.test_pose_worst`), D, A, E, cond (:mod:`.d_optimal`, :mod:`.a_optimal`,
:mod:`.e_optimal`, :mod:`.condition`) — by name in :mod:`.registry`, and the classic criteria of a
plan together (:mod:`.classic`)."""
