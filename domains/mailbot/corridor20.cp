% The mail robot in a corridor of 20 offices with up to ten requests in flight: the scaled
% variant of mailbot.cp (same rules, core.cp), for benchmarks (bench/bench_serve.py).

:- sorts
  office.

:- objects
  office1, office2, office3, office4, office5, office6, office7, office8, office9, office10,
  office11, office12, office13, office14, office15, office16, office17, office18, office19, office20 :: office.

:- macros
  capacity -> 3;
  slots -> 10;
  % office #2 is next to office #1, up the corridor
  next(#1,#2) ->
   (
       (#1 == office1 & #2 == office2)
    ++ (#1 == office2 & #2 == office3)
    ++ (#1 == office3 & #2 == office4)
    ++ (#1 == office4 & #2 == office5)
    ++ (#1 == office5 & #2 == office6)
    ++ (#1 == office6 & #2 == office7)
    ++ (#1 == office7 & #2 == office8)
    ++ (#1 == office8 & #2 == office9)
    ++ (#1 == office9 & #2 == office10)
    ++ (#1 == office10 & #2 == office11)
    ++ (#1 == office11 & #2 == office12)
    ++ (#1 == office12 & #2 == office13)
    ++ (#1 == office13 & #2 == office14)
    ++ (#1 == office14 & #2 == office15)
    ++ (#1 == office15 & #2 == office16)
    ++ (#1 == office16 & #2 == office17)
    ++ (#1 == office17 & #2 == office18)
    ++ (#1 == office18 & #2 == office19)
    ++ (#1 == office19 & #2 == office20)
   ).

:- include 'core.cp'; 'moves.cp'.

% The standing goal: nothing pending.  The robot starts at office1 with nothing to do.  A plan
% may be long: ten requests at opposite ends of the corridor.
:- query
  label :: serve;
  maxstep :: 0..200;
  0: at=office1 & load=0 & [/\P | phase(P)=idle & origin(P)=none & dest(P)=none];
  maxstep: [/\P | -pending(P)].
