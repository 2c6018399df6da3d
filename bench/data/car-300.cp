% A car on a 300 m road, as a discretised hybrid automaton: integer position, speed and
% clock over wide ranges; `drive(D)` moves at the current speed for D seconds, `speedUp` and
% `slowDown` change the speed by 3 m/s; a school zone between 120 m and 180 m allows at most
% 6 m/s.  Written for the planner's benchmarks.

:- sorts
  position;
  speed;
  clock;
  duration.

:- objects
  0..300                     :: position;
  0..24                      :: speed;
  0..120                     :: clock;
  1..12                      :: duration.

:- variables
  P                          :: position;
  S                          :: speed;
  T                          :: clock;
  D, D1                      :: duration.

:- constants
  pos                        :: inertialFluent(position);
  spd                        :: inertialFluent(speed);
  clk                        :: inertialFluent(clock);
  drive(duration)            :: exogenousAction;
  speedUp, slowDown          :: exogenousAction.

drive(D) causes pos = P + S * D if pos = P & spd = S where P + S * D =< 300.
drive(D) causes clk = T + D if clk = T where T + D =< 120.
nonexecutable drive(D) if pos = P & spd = S where P + S * D > 300.
nonexecutable drive(D) if clk = T where T + D > 120.
nonexecutable drive(D) & drive(D1) where D < D1.

speedUp causes spd = S + 3 if spd = S where S + 3 =< 24.
slowDown causes spd = S - 3 if spd = S where S >= 3.
nonexecutable speedUp if spd = S where S + 3 > 24.
nonexecutable slowDown if spd = S where S < 3.
nonexecutable speedUp & slowDown.
nonexecutable speedUp & drive(D).
nonexecutable slowDown & drive(D).

% the school zone: no more than 6 m/s while any part of a drive is inside it
nonexecutable drive(D) if pos = P & spd = S where S > 6 & P + S * D >= 120 & P =< 180.

:- query
  label :: 0;
  maxstep :: 0..12;
  0: pos = 0 & spd = 0 & clk = 0;
  maxstep: pos = 300 & spd = 0 & clk =< 60.
