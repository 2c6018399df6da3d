; A robot with two grippers carries balls between two rooms (written for cplus): moving
; costs 3, picking and dropping 1; a ball may only be dropped in a room that is not full.
(define (domain gripper)
  (:requirements :typing :negative-preconditions :equality :conditional-effects
                 :universal-preconditions :action-costs)
  (:types room ball gripper)
  (:constants left right - gripper)
  (:predicates (at-robby ?r - room) (at ?b - ball ?r - room) (free ?g - gripper)
               (carry ?b - ball ?g - gripper) (full ?r - room))
  (:functions (total-cost) - number)
  (:action move
    :parameters (?from ?to - room)
    :precondition (and (at-robby ?from) (not (= ?from ?to)))
    :effect (and (at-robby ?to) (not (at-robby ?from)) (increase (total-cost) 3)))
  (:action pick
    :parameters (?b - ball ?r - room ?g - gripper)
    :precondition (and (at ?b ?r) (at-robby ?r) (free ?g))
    :effect (and (carry ?b ?g) (not (at ?b ?r)) (not (free ?g)) (not (full ?r))
                 (increase (total-cost) 1)))
  (:action drop
    :parameters (?b - ball ?r - room ?g - gripper)
    :precondition (and (carry ?b ?g) (at-robby ?r) (not (full ?r)))
    :effect (and (at ?b ?r) (free ?g) (not (carry ?b ?g))
                 (when (forall (?g2 - gripper) (or (= ?g2 ?g) (free ?g2))) (full ?r))
                 (increase (total-cost) 1))))
