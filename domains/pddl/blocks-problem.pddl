; Reverse the tower c-on-b-on-a.
(define (problem reverse-three)
  (:domain blocks)
  (:objects a b c - block)
  (:init (ontable a) (on b a) (on c b) (clear c) (handempty))
  (:goal (and (on a b) (on b c) (ontable c))))
