; Bridges: islands joined by one-way bridges. A derived predicate, (reach ?x ?y), holds where
; a path of bridges leads from ?x to ?y: the least fixpoint of its recursive rule, so that two
; islands whose bridges only lead to each other reach nothing else.
(define (domain bridges)
  (:requirements :typing :negative-preconditions :derived-predicates)
  (:types island)
  (:predicates (bridge ?x ?y - island) (reach ?x ?y - island) (crew ?x - island))
  (:derived (reach ?x ?y - island)
    (or (bridge ?x ?y)
        (exists (?z - island) (and (bridge ?x ?z) (reach ?z ?y)))))
  ; a crew builds one bridge from its island, where no path leads yet
  (:action build
    :parameters (?x ?y - island)
    :precondition (and (crew ?x) (not (reach ?x ?y)))
    :effect (and (bridge ?x ?y) (not (crew ?x)))))
