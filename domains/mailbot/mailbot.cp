% ROSoClingo's mail-delivery case study: four offices in a row, the robot in front of office1,
% up to three packages on board, up to three requests in flight.  The rules are in core.cp;
% requests and cancellations come from `cplus serve` (README.md beside this file):
%
%     cplus serve domains/mailbot/mailbot.cp --script domains/mailbot/table1.jsonl

:- sorts
  office.

:- objects
  office1, office2, office3, office4 :: office.

:- macros
  capacity -> 3;
  slots -> 3;
  % office #2 is next to office #1, up the corridor
  next(#1,#2) ->
   (
       (#1 == office1 & #2 == office2)
    ++ (#1 == office2 & #2 == office3)
    ++ (#1 == office3 & #2 == office4)
   ).

:- include 'core.cp'; 'moves.cp'.

% The standing goal: nothing pending.  The robot starts at office1 with nothing to do.
:- query
  label :: serve;
  maxstep :: 0..40;
  0: at=office1 & load=0 & [/\P | phase(P)=idle & origin(P)=none & dest(P)=none];
  maxstep: [/\P | -pending(P)].
