"""The kinematic model: the robot (:mod:`.robot`), its geometric parameters (:mod:`.parameters`),
which of them measurements can identify (:mod:`.base_parameters`) and the parameter Jacobians
(:mod:`.jacobian`). The first stage of robot → parameters → Jacobians → criteria → design →
(simulate | identify) → export / view."""
