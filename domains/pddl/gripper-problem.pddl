; Two balls from rooma to roomb.
(define (problem two-balls)
  (:domain gripper)
  (:objects rooma roomb - room ball1 ball2 - ball)
  (:init (at-robby rooma) (free left) (free right) (at ball1 rooma) (at ball2 rooma)
         (= (total-cost) 0))
  (:goal (and (at ball1 roomb) (at ball2 roomb)))
  (:metric minimize (total-cost)))
