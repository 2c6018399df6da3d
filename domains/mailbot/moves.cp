% Moving along the corridor from an office to its neighbour, as ROSoClingo's robot does with
% move_base: one office per step, one action per step.  Included after core.cp, with the macro
% next(#1,#2) (office #2 is next to office #1, up the corridor).

:- constants
  move(office)                 :: exogenousAction.           % to a neighbouring office

move(O) causes at=O.
nonexecutable move(O) if at=O1 where -(next(O1,O) ++ next(O,O1)).

nonexecutable move(O) & move(O1) where O @< O1.
nonexecutable move(O) & pickup(P).
nonexecutable move(O) & deliver(P).
