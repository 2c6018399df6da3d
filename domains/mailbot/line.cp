% The mail robot as Legolog's LEGO robot: the four offices are landmarks along a black line
% that the robot follows (nxt_link's emulated delivery robot, or a real one).  It follows the
% line to the next office in the direction it faces, turns around on the spot, raises its
% tray to take a package and lowers it to hand one over.  The rules of requests and packages
% are those of core.cp; only moving differs from mailbot.cp:
%
%     cplus serve domains/mailbot/line.cp --robot domains/mailbot/robot.toml --script domains/mailbot/table1.jsonl
%
% robot.toml beside this file binds the actions to the brick program's behaviours and the
% landmark the follower reports to the fluent `at`; world.toml is the emulated track.

:- sorts
  office; direction.

:- objects
  office1, office2, office3, office4 :: office;
  up, down                           :: direction.

:- macros
  capacity -> 3;
  slots -> 3;
  % office #2 is next to office #1, up the line
  next(#1,#2) ->
   (
       (#1 == office1 & #2 == office2)
    ++ (#1 == office2 & #2 == office3)
    ++ (#1 == office3 & #2 == office4)
   ).

:- include 'core.cp'.

:- variables
  O2                           :: office.

:- constants
  facing                       :: inertialFluent(direction);   % up: towards office4
  between                      :: inertialFluent;     % stopped on the line between `at` and the next office up
  follow                       :: exogenousAction;    % follow the line to the next office
  turn                         :: exogenousAction;    % turn 180 degrees onto the line
  missed                       :: exogenousAction;    % the follower drove past an office
  halted                       :: exogenousAction.    % the follow was stopped part-way (cplus serve --preempt stop)

% Following the line: to the next office, or the one after it when the follower misses one
% (an event nothing reports: the landmark the robot stops at says so).
follow causes at=O1 if at=O & facing=up & -between & -missed & -halted where next(O,O1).
follow causes at=O1 if at=O & facing=down & -between & -missed & -halted where next(O1,O).
follow causes at=O2 if at=O & facing=up & -between & missed where next(O,O1) & next(O1,O2).
follow causes at=O2 if at=O & facing=down & -between & missed where next(O1,O) & next(O2,O1).
nonexecutable follow if at=office4 & facing=up.
nonexecutable follow if at=office1 & facing=down & -between.
nonexecutable missed if -follow.
nonexecutable missed if at=office3 & facing=up.
nonexecutable missed if at=office2 & facing=down & -between.
nonexecutable missed if at=office1 & facing=down.

% Stopped part-way (a goal preempted with --preempt stop): the robot stands on the line between
% two offices, `at` the one down the line.  From there it follows to the office ahead of it:
% the next one up, or `at` itself facing down (one further when it misses one).
follow causes between if halted.
follow causes at=O1 if at=O & facing=down & -between & halted where next(O1,O).
follow causes -between if -halted.
follow causes at=O1 if at=O & facing=up & between & -missed & -halted where next(O,O1).
follow causes at=O2 if at=O & facing=up & between & missed where next(O,O1) & next(O1,O2).
follow causes at=O1 if at=O & facing=down & between & missed where next(O1,O).
nonexecutable halted if -follow.
nonexecutable halted & missed.
nonexecutable pickup(P) if between.
nonexecutable deliver(P) if between.

turn causes facing=down if facing=up.
turn causes facing=up if facing=down.

% One behaviour at a time.
nonexecutable follow & turn.
nonexecutable follow & pickup(P).
nonexecutable follow & deliver(P).
nonexecutable turn & pickup(P).
nonexecutable turn & deliver(P).

% The standing goal: nothing pending.  The robot starts at office1 facing office2.
:- query
  label :: serve;
  maxstep :: 0..40;
  0: at=office1 & facing=up & -between & load=0 & [/\P | phase(P)=idle & origin(P)=none & dest(P)=none];
  maxstep: [/\P | -pending(P)].
